"""The spectra gallery (every judged track a panel, titles apart, no F without a peak, P_thr
and the pace band drawn) and report.html (one table row per verdict, self-contained, loads in
a real headless Chromium with no console error; skipped where no Chromium is installed)."""

from __future__ import annotations

import html.parser
import json
import math
import os
import re
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.cli.report import read_verdicts_head, render_report, report_path
from rhythmjax.cli.spectra import gallery_figures, panel_text, write_spectra
from rhythmjax.io import read_table
from rhythmjax.model.params import Config
from rhythmjax.model.status import Reason, Verdict

from .browser import Browser, find_chromium


class Row(NamedTuple):
    frame: int
    t: float
    intensity: float


def _obj(tid, verdict, reason, pace=2.0, n=64, fps=15.0, seed=0):
    """A judged track (or unjudged: verdict None) as the online tracker keeps it."""
    rng = np.random.default_rng(seed + tid)
    t = np.arange(n) / fps
    inten = 100 + 30 * np.sin(2 * np.pi * 2.0 * t) + rng.normal(0, 5, n)
    rows = [Row(k, float(t[k]), float(inten[k])) for k in range(n)]
    result = None if verdict is None else {
        "window": (0, n), "verdict": int(verdict), "reason": int(reason),
        "pace_hz": pace, "stride_m": 0.7 if math.isfinite(pace) else math.nan}
    return SimpleNamespace(track_id=tid, rows=rows, result=result)


def _population(n_judged=26):
    kinds = [(Verdict.PEDESTRIAN, Reason.MATCHED, 2.0),
             (Verdict.NON_PEDESTRIAN, Reason.NO_PEAK, 0.3),
             (Verdict.NON_PEDESTRIAN, Reason.NO_MODEL_MATCH, 0.25)]
    objs = [_obj(k + 1, *kinds[k % 3]) for k in range(n_judged)]
    return objs + [_obj(100, None, None), _obj(101, None, None)]  # too short: no panel


class Tables(html.parser.HTMLParser):
    """Rows of each table (by id) and the img sources of a page."""

    def __init__(self):
        super().__init__()
        self.rows: dict[str, int] = {}
        self.cells: dict[str, list[list[str]]] = {}
        self.images: list[str] = []
        self.links: list[str] = []
        self._table = None
        self._in_body = False
        self._cell = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self._table = a.get("id")
            self.rows[self._table] = 0
            self.cells[self._table] = []
        elif tag == "tbody":
            self._in_body = True
        elif tag == "tr" and self._in_body:
            self.rows[self._table] += 1
            self.cells[self._table].append([])
        elif tag == "td" and self._in_body:
            self._cell = ""
        elif tag == "img":
            self.images.append(a["src"])
        elif tag in ("a", "video") and a.get("href", a.get("src")):
            self.links.append(a.get("href", a.get("src")))

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data

    def handle_endtag(self, tag):
        if tag == "tbody":
            self._in_body = False
        elif tag == "td" and self._cell is not None:
            self.cells[self._table][-1].append(self._cell)
            self._cell = None


def _parse(page: str) -> Tables:
    p = Tables()
    p.feed(page)
    return p


# -- spectra gallery ----------------------------------------------------------------------------
def test_every_judged_track_has_a_panel_and_titles_do_not_overlap():
    cfg = Config()
    objs = _population(26)
    seen, pages = [], 0
    for plt, fig in gallery_figures(cfg, objs, per_page=12):
        pages += 1
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        boxes = [fig._suptitle.get_window_extent(r)]  # noqa: SLF001 - matplotlib's
        boxes += [t.get_window_extent(r) for lg in fig.legends for t in lg.get_texts()]
        for ax in fig.axes:
            title = ax.get_title(loc="left")
            if not title:
                continue
            seen.append(int(re.match(r"track #(\d+)", title).group(1)))
            boxes.append(ax._left_title.get_window_extent(r))  # noqa: SLF001 - matplotlib's
            boxes += [t.get_window_extent(r) for t in ax.texts]
            boxes.append(ax.xaxis.label.get_window_extent(r))
            lines = ax.get_lines()
            assert any(np.allclose(ln.get_ydata(), float(cfg.thresholds.p_thr)) for ln in lines)
            band = [p for p in ax.patches if "pace band" in p.get_label()]
            lo = float(cfg.walking.pace_mean - cfg.thresholds.k_sigma3 * cfg.walking.pace_std)
            assert len(band) == 1 and math.isclose(band[0].get_x(), lo, rel_tol=1e-5)
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not a.overlaps(b), (a, b)
        plt.close(fig)
    assert pages == 3
    assert sorted(seen) == list(range(1, 27))  # every judged track once, the unjudged none


def test_no_F_where_there_is_no_peak_and_non_pedestrian_figures_marked():
    ped = panel_text(_obj(1, Verdict.PEDESTRIAN, Reason.MATCHED, 1.9).result)
    assert ped[2] == "F 1.90 Hz, T 0.70 m"
    nopeak = panel_text(_obj(2, Verdict.NON_PEDESTRIAN, Reason.NO_PEAK, 0.28).result)
    assert "F " not in nopeak[2] and "no peak" in nopeak[2]
    bike = panel_text(_obj(3, Verdict.NON_PEDESTRIAN, Reason.NO_MODEL_MATCH, 0.22).result)
    assert "F 0.22 Hz" in bike[2] and "not meaningful" in bike[2]
    bad = panel_text(_obj(4, Verdict.UNCLASSIFIED, Reason.BAD_SIGNAL, math.nan).result)
    assert "F " not in bad[2] and "unusable" in bad[2]


def test_write_spectra_pdf_holds_every_page(tmp_path):
    png, pdf = tmp_path / "spectra.png", tmp_path / "spectra.pdf"
    pages = write_spectra(png, pdf, Config(), _population(26))
    assert len(pages) == 3 and png.read_bytes() == pages[0]
    assert len(re.findall(rb"/Type\s*/Page\b(?!s)", pdf.read_bytes())) == 3
    assert sorted(os.listdir(tmp_path)) == ["spectra.pdf", "spectra.png"]  # no temp left


# -- report.html --------------------------------------------------------------------------------
def test_report_table_has_one_row_per_verdict_and_marks_non_gait_figures():
    v = {"track_id": np.array([1, 2, 3]),
         "verdict": np.array(["pedestrian", "non-pedestrian", "unclassified"], object),
         "reason": np.array(["matched", "no-model-match", "too-short"], object),
         "pace_hz": np.array([2.0, 0.22, np.nan]), "stride_m": np.array([0.7, 14.7, np.nan])}
    page = render_report(title="t <x>", summary={"n_tracks": 3, "notes": ["a & b"]},
                         verdicts=v, config={"camera": {"h_m": 3.0}}, spectra=[b"\x89PNG"],
                         truth_ids={1: "ped000", 2: "bic004"})
    p = _parse(page)
    assert p.rows["verdicts"] == 3
    assert [c[1] for c in p.cells["verdicts"]] == ["ped000", "bic004", ""]
    assert p.cells["verdicts"][1][4] == "(0.220)" and p.cells["verdicts"][0][4] == "2.000"
    assert "t &lt;x&gt;" in page and "a &amp; b" in page
    assert p.images == ["data:image/png;base64,iVBORw=="]
    few = render_report(title="t", summary={}, verdicts=v, max_rows=2, n_tracks=10)
    assert _parse(few).rows["verdicts"] == 2 and "first 2 of 10" in few


def test_classify_report_path_and_head(tmp_path):
    assert report_path(str(tmp_path / "v.csv")) == str(tmp_path / "v.report.html")
    assert report_path(str(tmp_path / "ds") + "/") == str(tmp_path / "ds.report.html")
    (tmp_path / "v.csv").write_text("track_id,verdict\n" + "".join(f"{k},pedestrian\n"
                                                                   for k in range(30)))
    head = read_verdicts_head(str(tmp_path / "v.csv"), 7)
    assert list(head["track_id"]) == list(range(7))


def test_classify_writes_a_report_beside_the_verdicts(tmp_path, capsys):
    src, out = tmp_path / "t.csv", tmp_path / "v.parquet"
    assert main(["simulate", "-o", str(src), "--walkers", "3", "--bicycles", "1", "--dogs", "0",
                 "--cars", "0", "--short", "1", "-q"]) == 0
    assert main(["classify", str(src), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    page = (tmp_path / "v.report.html").read_text()
    assert summary["report"] == str(tmp_path / "v.report.html")
    p = _parse(page)
    assert p.rows["verdicts"] == summary["n_tracks"] == 5
    assert sorted(c[1] for c in p.cells["verdicts"]).count("pedestrian") == 4  # the labels
    assert p.links == ["v.parquet"]
    assert main(["classify", str(src), "-o", str(tmp_path / "w.csv"), "--no-report", "-q"]) == 0
    assert not (tmp_path / "w.report.html").exists()


@pytest.fixture(scope="module")
def demo_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    assert main(["demo", "-o", str(out), "--frames", "90", "--walkers", "2", "-q",
                 "--json"]) == 0
    return out


def test_demo_report_is_self_contained_and_matches_the_verdicts(demo_report):
    out = demo_report
    page = (out / "report.html").read_text()
    verdicts = read_table(out / "verdicts.csv", required=["track_id", "verdict", "reason"])
    p = _parse(page)
    assert p.rows["verdicts"] == len(verdicts["track_id"])
    judged = int(np.sum(np.asarray(verdicts["reason"]) != "too-short"))
    spectra = [s for s in p.images if s.startswith("data:image/png")]
    assert len(spectra) == max(1, math.ceil(judged / 12))
    assert all(s.startswith("data:") for s in p.images)  # no file the page needs beside it
    for link in p.links:  # links to the outputs are relative and exist
        assert not os.path.isabs(link) and (out / link).exists(), link
    assert "Config used" in page and "truth" in page


def test_run_and_count_reports_listed_and_skippable(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["demo", "-o", str(out), "--frames", "30", "--walkers", "1", "--no-overlay",
                 "-q", "--json"]) == 0
    assert (out / "report.html").exists() and (out / "spectra.pdf").exists()
    assert main(["demo", "-o", str(out), "--frames", "30", "--walkers", "1", "--no-overlay",
                 "--no-report", "-q", "--json"]) == 0
    assert not (out / "report.html").exists()  # an old report is removed with the set
    json.loads(capsys.readouterr().out.splitlines()[-1])


CHROMIUM = find_chromium()


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (apt-get install chromium)")
def test_report_loads_in_headless_chromium_without_console_errors(demo_report, tmp_path):
    with Browser(CHROMIUM) as b:
        b.load((demo_report / "report.html").as_uri())
        assert b.console_errors() == []
        rows = b.evaluate("document.querySelectorAll('#verdicts tbody tr').length")
        verdicts = read_table(demo_report / "verdicts.csv", required=["track_id"])
        assert rows == len(verdicts["track_id"])
        shown = b.evaluate("(() => { const r = document.querySelector('#verdicts')"
                           ".getBoundingClientRect(); return [r.width, r.height]; })()")
        assert shown[0] > 300 and shown[1] > 20 * rows
        widths = b.evaluate("Array.from(document.images).map(i => i.naturalWidth)")
        assert widths and all(w > 0 for w in widths)  # every image decoded
        shot = tmp_path / "report.png"
        b.screenshot(shot)
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20000
        # a broken page is caught: the check is not blind
        bad = tmp_path / "bad.html"
        bad.write_text('<!DOCTYPE html><img src="missing.png"><script>nope()</script>')
        b.load(bad.as_uri())
        assert len(b.console_errors()) >= 2


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium here (apt-get install chromium)")
def test_webm_overlay_plays_in_headless_chromium(tmp_path):
    """--overlay-format webm: the report's <video> decodes (the mp4v default does not in
    Chromium): ready with its first frame, no media error, the frame size of the scene."""
    import time

    out = tmp_path / "out"
    assert main(["demo", "-o", str(out), "--frames", "30", "--walkers", "1", "-q",
                 "--overlay-format", "webm"]) == 0
    with Browser(CHROMIUM) as b:
        b.load((out / "report.html").as_uri())
        state = "document.querySelector('video').readyState"
        t0 = time.monotonic()
        while b.evaluate(state) < 2 and time.monotonic() - t0 < 20:
            time.sleep(0.2)
        assert b.evaluate(state) >= 2  # HAVE_CURRENT_DATA: decoded
        assert b.evaluate("document.querySelector('video').error") is None
        assert b.evaluate("document.querySelector('video').videoWidth") == 512
        assert b.console_errors() == []


# -- count: spectra of the windows the batch classifier decided on -------------------------------
def _count_scene():
    """Crossing walkers and a bicycle in the small camera of tests/test_pedestrians.py, 15 fps."""
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.scene import SceneSpec, bicycle, render_scene, walker

    from .test_pedestrians import SMALL

    cfg = config_from_dict(SMALL)
    actors = (walker(-4.0, 6.5, 0.0, start_frame=2, phase=0.1),
              walker(4.0, 9.5, math.pi, start_frame=3, phase=0.6, grey_torso=150, grey_legs=70),
              bicycle(-6.0, 12.0, 0.0, speed_mps=2.0, start_frame=0))
    return SMALL, cfg, render_scene(3, SceneSpec(n_frames=100, actors=actors,
                                                 camera=cfg.camera)).frames


@pytest.fixture(scope="module")
def count_report(tmp_path_factory):
    import cv2

    small, _, frames = _count_scene()
    root = tmp_path_factory.mktemp("count_report")
    (root / "frames").mkdir()
    for k, f in enumerate(frames):
        assert cv2.imwrite(str(root / "frames" / f"f{k:03d}.png"), f)
    (root / "small.json").write_text(json.dumps(small))
    out = root / "out"
    assert main(["count", str(root / "frames"), "-c", str(root / "small.json"), "-o", str(out),
                 "--fps", "15", "-q", "--overlay", str(out / "overlay.mp4")]) == 0
    return root, out


def _pdf_pages(path) -> int:
    return len(re.findall(rb"/Type\s*/Page\b(?!s)", path.read_bytes()))


def test_count_writes_spectra_of_every_judged_track(count_report, capsys):
    root, out = count_report
    verdicts = read_table(out / "verdicts.csv", required=["track_id", "verdict", "reason"])
    judged = int(np.sum(~np.isin(verdicts["reason"], ["too-short", "no-measurements"])))
    assert judged >= 3  # two walkers and the bicycle
    pages = max(1, math.ceil(judged / 12))
    assert _pdf_pages(out / "spectra.pdf") == pages
    assert (out / "spectra.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    p = _parse((out / "report.html").read_text())
    assert len([s for s in p.images if s.startswith("data:image/png")]) == pages
    assert "spectra.pdf" in p.links and "spectra.png" in p.links
    # --no-report: the spectra stay, the old report goes with the set
    assert main(["count", str(root / "frames"), "-c", str(root / "small.json"), "-o",
                 str(root / "again"), "--fps", "15", "-q"]) == 0
    assert (root / "again" / "report.html").exists()
    assert main(["count", str(root / "frames"), "-c", str(root / "small.json"), "-o",
                 str(root / "again"), "--fps", "15", "-q", "--no-report"]) == 0
    assert not (root / "again" / "report.html").exists()
    assert _pdf_pages(root / "again" / "spectra.pdf") == pages


def test_count_spectra_windows_are_the_deciding_windows():
    """Each window `table_windows` rebuilds from count's tables, classified alone by
    `rhythm.classify_window` (the reference, its speed given), gives the track's verdict,
    reason and pace (1e-5 relative): the spectrum drawn is the one that decided."""
    import jax.numpy as jnp

    from rhythmjax.cli.spectra import table_windows
    from rhythmjax.count import count_frames
    from rhythmjax.model.rhythm import classify_window
    from rhythmjax.model.status import REASON_LABELS, VERDICT_LABELS

    _, cfg, frames = _count_scene()
    res = count_frames(cfg, ((i, i / 15.0, f) for i, f in enumerate(frames)))
    v = res.verdicts
    wins = table_windows(res.tracks, v, cfg.thresholds.n, 15.0)
    judged = ~np.isin(v["reason"], ["too-short", "no-measurements"])
    assert [w.track_id for w in wins] == [int(t) for t in v["track_id"][judged]]
    assert len(wins) >= 3 and {w.result["verdict"] for w in wins} == {1, 2}  # both verdicts
    for w in wins:
        i = list(v["track_id"]).index(w.track_id)
        assert len(w.rows) == cfg.thresholds.n
        inten = jnp.asarray([r.intensity for r in w.rows], jnp.float32)
        t = jnp.asarray([r.t - w.rows[0].t for r in w.rows], jnp.float32)
        r = classify_window(cfg, inten, t, jnp.zeros((len(w.rows), 2), jnp.float32),
                            jnp.asarray(True), speed=jnp.float32(v["speed_mps"][i]))
        assert VERDICT_LABELS[int(r.verdict)] == v["verdict"][i]
        assert REASON_LABELS[int(r.reason)] == v["reason"][i]
        np.testing.assert_allclose(float(r.pace_hz), float(v["pace_hz"][i]), rtol=1e-5,
                                   equal_nan=True)
        assert w.result["verdict"] == int(r.verdict) and w.result["window"] == (0, len(w.rows))


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (apt-get install chromium)")
def test_count_report_loads_in_headless_chromium(count_report, tmp_path):
    _, out = count_report
    with Browser(CHROMIUM) as b:
        b.load((out / "report.html").as_uri())
        assert b.console_errors() == []
        rows = b.evaluate("document.querySelectorAll('#verdicts tbody tr').length")
        verdicts = read_table(out / "verdicts.csv", required=["track_id"])
        assert rows == len(verdicts["track_id"]) >= 2
        widths = b.evaluate("Array.from(document.images).map(i => i.naturalWidth)")
        alts = b.evaluate("Array.from(document.images).map(i => i.alt)")
        assert any(a.startswith("spectra page") for a in alts)
        assert widths and all(w > 0 for w in widths)  # every image decoded
        shot = os.environ.get("RHYTHMJAX_SHOT_DIR")  # keep the screenshot to look at
        b.screenshot(os.path.join(shot, "count_report.png") if shot else tmp_path / "s.png")
