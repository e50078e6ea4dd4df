"""What a person looks at in an annotated video (edge I/O, OpenCV; the numeric core never imports
this): each object coloured by its verdict, labelled in words ("#4 pedestrian", "#7 undecided,
predicted"), labels kept inside the frame and placed so that they do not overlap each other or
the legend (greedy placement of label boxes), a short trail of the last foot points, and a
legend strip with the frame index.

`TrackOverlay` is the stateful drawer (it remembers the trails) used by `run`, `demo`, `track`
and `count`; `draw_frame` and `draw_count_frame` draw one frame without a trail. The pipeline
works on grey frames; `in_colour` gives the drawer the source's own colour frame where it has
one (`vision.video.VideoSource.keep_colour`: kept from the one decode, not read twice)."""

from __future__ import annotations

import math
from collections import deque

import cv2
import numpy as np

from ..model.params import WidthModel


__all__ = ["PALETTE", "FrameSampler", "TrackOverlay", "draw_count_frame", "draw_frame",
           "in_colour", "label_text", "place_labels", "verdict_key"]

# BGR colours by verdict: green walkers, red non-walkers, amber undecided, grey tentative
PALETTE = {"pedestrian": (60, 200, 40), "non-pedestrian": (60, 60, 235),
           "undecided": (0, 190, 255), "tentative": (170, 170, 170)}
LEGEND = (("pedestrian", "pedestrian"), ("non-pedestrian", "non-pedestrian"),
          ("undecided", "undecided"))
FONT = cv2.FONT_HERSHEY_SIMPLEX
TRAIL = 15  # foot points kept per track
PAD = 2  # px around a label's text

Box = tuple[int, int, int, int]  # x0, y0, x1, y1 (px; x1, y1 exclusive)


def verdict_key(verdict: str | None, track_id: int = 1) -> str:
    """The PALETTE key of a verdict label (None and "unclassified" are "undecided"; track id 0,
    a tentative `count` patch, is "tentative")."""
    if track_id == 0:
        return "tentative"
    return verdict if verdict in ("pedestrian", "non-pedestrian") else "undecided"


def label_text(track_id: int, verdict: str | None, state: str | None = None) -> tuple[str, str]:
    """(full, short) label of an object in words: "#4 pedestrian", "#7 undecided, predicted";
    the short form is the id alone ("#4"; "new" for a tentative `count` patch)."""
    if track_id == 0:
        return "new", "new"
    full = f"#{track_id} {verdict_key(verdict, track_id)}"
    if state == "predict":
        full += ", predicted"
    return full, f"#{track_id}"


def _font_scale(height: int) -> float:
    return float(np.clip(height / 1000.0, 0.35, 0.7))


def text_box_size(text: str, scale: float) -> tuple[int, int]:
    """(width, height) px of a label box holding `text` at font `scale` (padding included)."""
    (w, h), base = cv2.getTextSize(text, FONT, scale, 1)
    return w + 2 * PAD, h + base + 2 * PAD


def _overlaps(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _clamped(x0: float | int, y0: float | int, w: int, h: int, width: int, height: int) -> Box:
    x = int(round(min(max(x0, 0), width - w)))
    y = int(round(min(max(y0, 0), height - h)))
    return x, y, x + w, y + h


def _candidates(anchor: Box, w: int, h: int, width: int, height: int):
    """Label positions near the object box `anchor`, nearest first, each clamped to the frame:
    above it, below it, at its right and left, then stepped further up and down."""
    ax0, ay0, ax1, ay1 = anchor
    cx = (ax0 + ax1) / 2
    spots = [(ax0, ay0 - h), (cx - w / 2, ay0 - h), (ax0, ay1 + 1), (ax1 + 2, ay0),
             (ax0 - w - 2, ay0), (ax1 + 2, ay1 - h), (ax0 - w - 2, ay1 - h)]
    for k in range(1, max(2, height // max(h, 1))):
        spots += [(ax0, ay0 - h - k * h), (ax0, ay1 + 1 + k * h),
                  (ax1 + 2, ay0 - k * h), (ax0 - w - 2, ay0 - k * h)]
    for x, y in spots:
        yield _clamped(x, y, w, h, width, height)


def place_labels(requests: list[tuple[Box, list[tuple[int, int]]]], width: int, height: int,
                 obstacles: list[Box] = ()) -> list[tuple[Box, int] | None]:
    """Greedy placement of label boxes: for each request (the object's box, and the label sizes
    to try, largest first), in the order given (put the most important first), the first
    candidate spot (`_candidates`) inside the frame that overlaps no label placed before and no
    obstacle (the legend); (box, index of the size used), or None when no size fits anywhere.
    The boxes returned lie inside the frame and are pairwise disjoint."""
    placed: list[Box] = []
    out: list[tuple[Box, int] | None] = []
    for anchor, sizes in requests:
        got = None
        for k, (w, h) in enumerate(sizes):
            if w > width or h > height:
                continue
            for box in _candidates(anchor, w, h, width, height):
                if not any(_overlaps(box, b) for b in placed) and \
                        not any(_overlaps(box, b) for b in obstacles):
                    got = (box, k)
                    break
            if got:
                break
        if got:
            placed.append(got[0])
        out.append(got)
    return out


def _dashed_rect(img, p0, p1, colour, dash: int = 5) -> None:
    (x0, y0), (x1, y1) = p0, p1
    for a, b in (((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)),
                 ((x0, y1), (x0, y0))):
        n = max(1, int(math.hypot(b[0] - a[0], b[1] - a[1]) // dash))
        for i in range(0, n, 2):
            s = (int(a[0] + (b[0] - a[0]) * i / n), int(a[1] + (b[1] - a[1]) * i / n))
            e = (int(a[0] + (b[0] - a[0]) * min(i + 1, n) / n),
                 int(a[1] + (b[1] - a[1]) * min(i + 1, n) / n))
            cv2.line(img, s, e, colour, 1, cv2.LINE_AA)


class TrackOverlay:
    """Draws annotated frames and remembers each track's last foot points for its trail.

    kind "run": snapshots of the online tracker (track_id, u, v, width, state, verdict); each
    detection window is `height_per_width` times its width tall. kind "count": snapshots of
    `count`'s pedestrian level (track_id (0 tentative), box (left, top, w, h), measured,
    verdict). After each call `labels` holds (track_id, text, box) of the labels drawn,
    `hidden` the ids whose label found no room and `legend` the legend strip's box."""

    def __init__(self, kind: str = "run", *, height_per_width: float | None = None,
                 trail: int = TRAIL):
        if kind not in ("run", "count"):
            raise ValueError(f"kind must be 'run' or 'count', got {kind!r}")
        self.kind = kind
        self.hpw = WidthModel().height_per_width() if height_per_width is None \
            else float(height_per_width)
        self.trail = int(trail)
        self.trails: dict[int, deque] = {}
        self.labels: list[tuple[int, str, Box]] = []
        self.hidden: list[int] = []
        self.legend: Box | None = None

    def __call__(self, frame: np.ndarray, index: int, snapshot: list[dict]) -> np.ndarray:
        """A BGR copy of `frame` (grey or BGR) with the snapshot's objects drawn."""
        img = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame.copy()
        H, W = img.shape[:2]
        scale = _font_scale(H)
        objs = [o for o in (self._object(s) for s in snapshot) if o is not None]
        self._update_trails(objs)
        legend, legend_items = self._legend_layout(W, H, scale, index,
                                                   sum(o["id"] != 0 for o in objs))
        self.legend = legend
        for o in objs:
            self._draw_object(img, o)
        order = sorted(range(len(objs)), key=lambda i: (objs[i]["key"] in ("undecided",
                                                                          "tentative"),
                                                         -objs[i]["box"][3]))
        reqs = []
        for i in order:
            full, short = objs[i]["text"]
            reqs.append((objs[i]["box"], [text_box_size(full, scale),
                                          text_box_size(short, scale)]))
        placed = place_labels(reqs, W, H, [legend])
        self.labels, self.hidden = [], []
        for i, got in zip(order, placed):
            o = objs[i]
            if got is None:
                self.hidden.append(o["id"])
                continue
            box, k = got
            self._draw_label(img, o, o["text"][k], box, scale)
            self.labels.append((o["id"], o["text"][k], box))
        self._draw_legend(img, legend, legend_items)
        return img

    # -- objects --------------------------------------------------------------------------------
    def _object(self, s: dict) -> dict | None:
        """One snapshot entry as id, foot point, box (x0, y0, x1, y1), colour key, label texts."""
        if self.kind == "run":
            u, v = s["u"], s["v"]
            if not (math.isfinite(u) and math.isfinite(v)):
                return None
            w = s["width"] if math.isfinite(s["width"]) else 20.0
            h = w * self.hpw
            box = (int(u - w / 2), int(v - h), int(u + w / 2), int(v))
            solid = s.get("state") != "predict"
            tid, state = int(s["track_id"]), s.get("state")
        else:
            left, top, w, h = s["box"]
            if not all(math.isfinite(q) for q in (left, top, w, h)):
                return None
            u, v = left + w / 2, top + h
            box = (int(round(left)), int(round(top)), int(round(left + w)),
                   int(round(top + h)))
            solid = bool(s.get("measured", True))
            tid, state = int(s["track_id"]), None if solid else "predict"
        key = verdict_key(s.get("verdict"), tid)
        return {"id": tid, "u": float(u), "v": float(v), "box": box, "solid": solid,
                "key": key, "text": label_text(tid, s.get("verdict"), state)}

    def _update_trails(self, objs: list[dict]) -> None:
        seen = set()
        for o in objs:
            if o["id"] == 0:
                continue
            seen.add(o["id"])
            self.trails.setdefault(o["id"], deque(maxlen=self.trail)).append((o["u"], o["v"]))
        for tid in [t for t in self.trails if t not in seen]:  # ended (or lost) tracks
            del self.trails[tid]

    def _draw_object(self, img, o: dict) -> None:
        c = PALETTE[o["key"]]
        pts = self.trails.get(o["id"], ())
        pts = [(int(round(u)), int(round(v))) for u, v in pts]
        for i in range(1, len(pts)):  # older segments thinner and fainter
            fade = 0.35 + 0.65 * i / len(pts)
            cv2.line(img, pts[i - 1], pts[i], tuple(int(ch * fade) for ch in c), 1, cv2.LINE_AA)
        x0, y0, x1, y1 = o["box"]
        if o["solid"]:
            cv2.rectangle(img, (x0, y0), (x1, y1), c, 2 if self.kind == "count" else 1)
        else:
            _dashed_rect(img, (x0, y0), (x1, y1), c)
        foot = (int(round(o["u"])), int(round(o["v"])))
        if o["solid"]:
            cv2.circle(img, foot, 3, c, -1, cv2.LINE_AA)
        else:
            cv2.circle(img, foot, 3, c, 1, cv2.LINE_AA)

    def _draw_label(self, img, o: dict, text: str, box: Box, scale: float) -> None:
        c = PALETTE[o["key"]]
        x0, y0, x1, y1 = box
        ax0, ay0, ax1, ay1 = o["box"]
        far = not (_overlaps(box, (ax0 - 3, ay0 - 3, ax1 + 3, ay1 + 3)))
        if far:  # a leader line from a displaced label to its box
            cx = min(max((x0 + x1) // 2, ax0), ax1)
            cy = min(max((y0 + y1) // 2, ay0), ay1)
            cv2.line(img, ((x0 + x1) // 2, (y0 + y1) // 2), (cx, cy), c, 1, cv2.LINE_AA)
        cv2.rectangle(img, (x0, y0), (x1 - 1, y1 - 1), c, -1)
        (_, th), base = cv2.getTextSize(text, FONT, scale, 1)
        ink = (0, 0, 0) if o["key"] != "non-pedestrian" else (255, 255, 255)
        cv2.putText(img, text, (x0 + PAD, y1 - PAD - base), FONT, scale, ink, 1, cv2.LINE_AA)

    # -- legend ---------------------------------------------------------------------------------
    def _legend_layout(self, W: int, H: int, scale: float, index: int, n_in: int):
        """The legend strip at the bottom (its box) and its items (colour or None, text, x,
        baseline), flowed into as many rows as the frame's width needs."""
        _, lh = text_box_size("Ag", scale)
        items = [(None, f"frame {index}  in view {n_in}")] + \
            [(PALETTE[k], w) for k, w in LEGEND] + [(None, "dashed: predicted"),
                                                   (None, "line: foot trail")]
        rows, x = [[]], 4
        for colour, text in items:
            (tw, th), _ = cv2.getTextSize(text, FONT, scale, 1)
            need = tw + (th + 3 if colour is not None else 0)
            if x + need > W - 2 and rows[-1]:
                rows.append([])
                x = 4
            rows[-1].append((colour, text, x, th))
            x += need + 10
        y0 = max(0, H - len(rows) * lh - 2)
        out = [(c, t, x, y0 + (r + 1) * lh - PAD - 2, th) for r, its in enumerate(rows)
               for c, t, x, th in its]
        return (0, y0, W, H), out

    def _draw_legend(self, img, box: Box, items) -> None:
        x0, y0, x1, y1 = box
        strip = img[y0:y1, x0:x1]
        strip[:] = (strip * 0.3).astype(np.uint8)  # darkened, the video still seen through
        scale = _font_scale(img.shape[0])
        for colour, text, x, base, th in items:
            if colour is not None:
                cv2.rectangle(img, (x, base - th), (x + th, base), colour, -1)
                x += th + 3
            cv2.putText(img, text, (x, base), FONT, scale, (255, 255, 255), 1, cv2.LINE_AA)


class FrameSampler:
    """Keeps a few annotated frames, evenly spaced, as JPEG bytes for the report (a browser
    plays no mp4v video): every `step`-th frame (n_frames // k when the length is known, else
    every 50th), at most `k`, scaled down to `width` px."""

    def __init__(self, n_frames: int | None = None, k: int = 8, width: int = 480):
        self.step = max(1, int(n_frames) // k) if n_frames else 50
        self.k, self.width = k, width
        self.frames: list[tuple[int, bytes]] = []

    def __call__(self, index: int, img: np.ndarray) -> np.ndarray:
        """Keep `img` if it is one of the sampled frames; returns it unchanged."""
        if index % self.step == self.step // 2 and len(self.frames) < self.k:
            h, w = img.shape[:2]
            small = img if w <= self.width else cv2.resize(
                img, (self.width, round(h * self.width / w)), interpolation=cv2.INTER_AREA)
            ok, buf = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 80])
            if ok:
                self.frames.append((index, buf.tobytes()))
        return img


def in_colour(src):
    """(frame, index) -> the frame to draw on: `src`'s colour frame of `index` where it kept
    one, else `frame` (grey). Sets `src.keep_colour` (a `VideoSource`; None: always `frame`);
    call once per decoded frame, in order (each call takes the kept frame)."""
    if src is None:
        return lambda frame, index: frame
    src.keep_colour = True

    def pick(frame, index):
        bgr = src.colour(index)
        return frame if bgr is None or bgr.shape[:2] != frame.shape[:2] else bgr
    return pick


def draw_frame(gray: np.ndarray, objects: list[dict], index: int, *,
               height_per_width: float | None = None) -> np.ndarray:
    """One annotated frame of the online tracker's snapshot `objects` (no trail: use
    `TrackOverlay("run")` across frames for one)."""
    return TrackOverlay("run", height_per_width=height_per_width)(gray, index, objects)


def draw_count_frame(gray: np.ndarray, pedestrians: list[dict], index: int) -> np.ndarray:
    """One annotated frame of `count`'s pedestrians (no trail: use `TrackOverlay("count")`
    across frames for one)."""
    return TrackOverlay("count")(gray, index, pedestrians)
