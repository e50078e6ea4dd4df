"""Self-calibration with the focal length held (`fit_selfcal(fit=("h", "theta"))`,
`rhythmjax-fit selfcal --hold-focal`): a known lens; h and the tilt fitted, a f kept at the
start config's, on a simulated scene of 20 walkers seen by a known camera."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fit.cli import main as fit_main
from fit.selfcal import fit_selfcal
from fit.selfcal_data import camera_values
from fit.walking import batch_of, make_labelled
from rhythmjax.io import write_table
from rhythmjax.model.params import Camera, Config


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
# the true lens, a wrong h and tilt
KNOWN_LENS = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=950 / F, b=950 / F,
                                  uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))
COLUMNS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "v_top")


@pytest.fixture(scope="module")
def scene():
    cols, _ = make_labelled(n_walkers=20, seed=11, camera=TRUE)
    return cols


def test_held_focal_length_stays_and_h_and_tilt_are_recovered(scene):
    """a f stays at the start's 950 px (to float32 rounding) and has no SE; h within 5 % and
    the tilt within 1 deg of the truth, each within 3 of its SE, and the tilt's SE under 1 deg
    (measured: h -4.3 %, SE 2.4 %; tilt +0.09 deg, SE 0.08 deg)."""
    r = fit_selfcal(KNOWN_LENS, batch_of(scene, KNOWN_LENS), fit=("h", "theta"))
    tv = camera_values(TRUE)
    assert not r.ill_determined and r.success, r.reasons
    assert r.fitted == ("h", "theta") and "af" not in r.se
    assert r.values["af"] == pytest.approx(950.0, rel=1e-6)
    for k, tol in (("h", 0.05 * tv["h"]), ("theta", 1.0)):
        err = abs(r.values[k] - tv[k])
        assert err <= tol and err <= 3 * r.se[k], (k, r.values[k], tv[k], r.se[k])
    assert r.se["theta"] < 1.0


def test_h_and_tilt_must_be_fitted():
    with pytest.raises(ValueError, match="h and theta"):
        fit_selfcal(KNOWN_LENS, None, fit=("af", "h"))


def test_the_command_needs_a_config_with_the_focal_length(tmp_path, scene, capsys):
    tracks = tmp_path / "tracks.csv"
    write_table(tracks, {k: v for k, v in scene.items() if k in COLUMNS},
                [c for c in COLUMNS if c in scene])
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"camera": {"image_width_px": 1280, "image_height_px": 720,
                                            "fps": 15}}))
    for extra in ([], ["-c", str(start)]):
        rc = fit_main(["selfcal", str(tracks), "--hold-focal", "-o", str(tmp_path / "c.json"),
                       "--image-size", "1280x720", *extra])
        assert rc == 2 and not (tmp_path / "c.json").exists()
        assert "--hold-focal" in capsys.readouterr().err
    lens = tmp_path / "lens.json"
    lens.write_text(json.dumps({"camera": {**json.loads(start.read_text())["camera"],
                                           "f_m": F, "a_px_per_m": 950 / F,
                                           "b_px_per_m": 950 / F}}))
    rc = fit_main(["selfcal", str(tracks), "-c", str(lens), "--hold-focal", "--json", "-o",
                   str(tmp_path / "c.json")])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["fitted"] == ["h", "theta"]
    cam = json.loads((tmp_path / "c.json").read_text())["camera"]
    assert cam["a_px_per_m"] * cam["f_m"] == pytest.approx(950.0, rel=1e-5)
    assert np.isfinite(doc["se"]["theta"])


def test_a_rounds_line_says_the_focal_length_was_held():
    """The video input's per-round line (`fit.selfcal_video.Round.line`) gives a held a f
    without an SE."""
    from types import SimpleNamespace

    from fit.selfcal_video import Round

    fit = SimpleNamespace(n_walkers=23, camera=object(), ill_determined=False, reasons=[],
                          values={"h": 6.65, "theta": 16.1, "af": 742.0},
                          se={"h": 0.4, "theta": 0.6})
    line = Round(2, {}, 184, fit).line(2)
    assert line == ("round 2 of 2: 184 tracks, 23 walkers: h 6.65 +- 0.40 m, tilt 16.1 +- 0.6 "
                    "deg, a f 742 px (held)")
    fit.se["af"] = 30.0
    assert Round(2, {}, 184, fit).line(2).endswith("a f 742 +- 30 px")
