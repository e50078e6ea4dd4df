"""Blob graph (rhythmjax/blobgraph.py): each event on constructed blob sets, and the exact solver
against a brute force over all edge subsets written independently (itertools + BFS)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
import pytest

from rhythmjax.vision.blobgraph import BlobGraph, blob_graph, candidate_edges, graph_cost
from rhythmjax.vision.blobs import Blob


def mk(x0: int, y0: int, x1: int, y1: int, area: int | None = None) -> Blob:
    a = (x1 - x0) * (y1 - y0) if area is None else area
    return Blob(box=(x0, y0, x1, y1), area=a, perimeter=0.0,
                centroid=((x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2),
                density=a / ((x1 - x0) * (y1 - y0)), label=1)


def _is_star_forest(edges: Sequence[tuple[int, int]]) -> bool:
    """Every connected part has one prev or one cur vertex (BFS over the chosen edges)."""
    adj: dict[tuple[str, int], set[tuple[str, int]]] = {}
    for i, j in edges:
        adj.setdefault(("p", i), set()).add(("c", j))
        adj.setdefault(("c", j), set()).add(("p", i))
    seen: set[tuple[str, int]] = set()
    for start in adj:
        if start in seen:
            continue
        comp, todo = {start}, [start]
        while todo:
            for nb in adj[todo.pop()]:
                if nb not in comp:
                    comp.add(nb)
                    todo.append(nb)
        seen |= comp
        if sum(s == "p" for s, _ in comp) > 1 and sum(s == "c" for s, _ in comp) > 1:
            return False
    return True


def _ref_cost(prev: Sequence[Blob], cur: Sequence[Blob], edges: Sequence[tuple[int, int]],
              lam: float) -> float:
    """Cost by the definition: per star |centre - sum of leaves|, lam * area when unmatched."""
    cost = 0.0
    kids = {i: [j for a, j in edges if a == i] for i in range(len(prev))}
    pars = {j: [i for i, b in edges if b == j] for j in range(len(cur))}
    done: set[tuple[int, int]] = set()
    for i, js in kids.items():
        if not js:
            cost += lam * prev[i].area
        elif len(js) >= 2 or len(pars[js[0]]) == 1:  # a split, or one-to-one
            cost += abs(prev[i].area - sum(cur[j].area for j in js))
            done |= {(i, j) for j in js}
    for j, is_ in pars.items():
        if not is_:
            cost += lam * cur[j].area
        elif not all((i, j) in done for i in is_):  # a merge
            cost += abs(cur[j].area - sum(prev[i].area for i in is_))
    return cost


def _brute_force(prev: Sequence[Blob], cur: Sequence[Blob], lam: float, margin: int) -> float:
    cands = [(i, j) for i, p in enumerate(prev) for j, c in enumerate(cur)
             if p.box[0] - margin < c.box[2] and c.box[0] < p.box[2] + margin
             and p.box[1] - margin < c.box[3] and c.box[1] < p.box[3] + margin]
    best = float("inf")
    for r in range(len(cands) + 1):
        for sub in itertools.combinations(cands, r):
            if _is_star_forest(sub):
                best = min(best, _ref_cost(prev, cur, sub, lam))
    return best


def _check_consistent(g: BlobGraph, prev: Sequence[Blob], cur: Sequence[Blob],
                      lam: float = 0.5) -> None:
    assert _is_star_forest(g.edges)
    assert g.cost == pytest.approx(_ref_cost(prev, cur, g.edges, lam), abs=1e-9)
    assert g.cost == pytest.approx(graph_cost(prev, cur, g.edges, unmatched_cost=lam), abs=1e-9)
    # every blob is in exactly one event
    used_p = list(g.vanished) + [i for i, _ in g.continued] + [i for i, _ in g.splits]
    used_p += [i for ps, _ in g.merges for i in ps]
    used_c = list(g.appeared) + [j for _, j in g.continued] + [j for _, j in g.merges]
    used_c += [j for _, js in g.splits for j in js]
    assert sorted(used_p) == list(range(g.n_prev))
    assert sorted(used_c) == list(range(g.n_cur))


def test_one_to_one_continuation_appear_vanish() -> None:
    prev = [mk(0, 0, 10, 20), mk(30, 0, 40, 20), mk(200, 0, 210, 20)]
    cur = [mk(3, 0, 13, 21), mk(33, 1, 43, 21), mk(100, 50, 110, 60)]
    g = blob_graph(prev, cur)
    assert g.continued == [(0, 0), (1, 1)]
    assert g.appeared == [2] and g.vanished == [2]
    assert g.merges == [] and g.splits == []
    assert g.cost == pytest.approx(10 + 0 + 0.5 * 200 + 0.5 * 100)
    assert g.children(0) == [0] and g.parents(1) == [1] and g.parents(2) == []
    _check_consistent(g, prev, cur)


@pytest.mark.parametrize("n", [2, 3])
def test_merge(n: int) -> None:
    prev = [mk(12 * k, 0, 12 * k + 10, 30) for k in range(n)]  # 300 px each
    cur = [mk(2, 0, 12 * n - 4, 30, area=300 * n - 20)]
    g = blob_graph(prev, cur)
    assert g.merges == [(tuple(range(n)), 0)]
    assert g.continued == [] and g.splits == [] and g.appeared == [] and g.vanished == []
    assert g.cost == pytest.approx(20)
    _check_consistent(g, prev, cur)


def test_split_into_two_with_a_newcomer_nearby() -> None:
    prev = [mk(0, 0, 30, 30, area=600), mk(100, 0, 110, 10)]
    # the split halves and a small blob that touches the box but would upset the balance
    cur = [mk(0, 0, 14, 30, area=290), mk(16, 0, 30, 30, area=300), mk(28, 28, 40, 40, area=400)]
    g = blob_graph(prev, cur)
    assert g.splits == [(0, (0, 1))]
    assert g.appeared == [2] and g.vanished == [1]
    assert g.cost == pytest.approx(10 + 0.5 * 400 + 0.5 * 100)
    _check_consistent(g, prev, cur)


def test_unmatched_cost_decides_between_split_and_appear() -> None:
    prev = [mk(0, 0, 20, 20, area=400)]
    cur = [mk(0, 0, 20, 20, area=390), mk(15, 15, 30, 30, area=100)]
    # split: |400 - 490| = 90 against continue + appear: 10 + lam * 100
    assert blob_graph(prev, cur, unmatched_cost=0.5).appeared == [1]
    assert blob_graph(prev, cur, unmatched_cost=1.0).splits == [(0, (0, 1))]


def test_two_independent_components() -> None:
    prev = [mk(0, 0, 10, 30), mk(12, 0, 22, 30), mk(300, 0, 330, 30, area=600)]
    cur = [mk(2, 0, 20, 30, area=590), mk(300, 0, 314, 30, area=300),
           mk(316, 0, 330, 30, area=300)]
    g = blob_graph(prev, cur)
    assert g.merges == [((0, 1), 0)] and g.splits == [(2, (1, 2))]
    assert g.n_components == 2 and g.n_greedy == 0
    assert g.cost == pytest.approx(10)
    _check_consistent(g, prev, cur)


def test_margin_joins_fast_movers() -> None:
    prev, cur = [mk(0, 0, 10, 20)], [mk(13, 0, 23, 20)]  # a 3-px gap between the boxes
    assert blob_graph(prev, cur, margin=2).appeared == [0]
    assert blob_graph(prev, cur, margin=4).continued == [(0, 0)]


def test_empty_frames() -> None:
    blobs = [mk(0, 0, 10, 10), mk(20, 0, 30, 10)]
    g = blob_graph([], [])
    assert (g.n_prev, g.n_cur, g.edges, g.cost) == (0, 0, (), 0.0)
    g = blob_graph(blobs, [])
    assert g.vanished == [0, 1] and g.appeared == [] and g.cost == pytest.approx(100)
    g = blob_graph([], blobs)
    assert g.appeared == [0, 1] and g.vanished == [] and g.cost == pytest.approx(100)


def _random_scene(rng: np.random.Generator, n_p: int, n_c: int) -> tuple[list[Blob], list[Blob]]:
    def boxes(n: int) -> list[Blob]:
        out = []
        for _ in range(n):
            x0, y0 = rng.integers(0, 30, 2)
            w, h = rng.integers(4, 16, 2)
            out.append(mk(int(x0), int(y0), int(x0 + w), int(y0 + h),
                          area=int(rng.integers(1, w * h + 1))))
        return out
    return boxes(n_p), boxes(n_c)


def test_exact_solver_against_brute_force() -> None:
    rng = np.random.default_rng(7)
    n_cases = n_multi = 0
    while n_cases < 200:
        prev, cur = _random_scene(rng, int(rng.integers(1, 5)), int(rng.integers(1, 5)))
        lam = float(rng.choice([0.25, 0.5, 1.0]))
        if len(candidate_edges(prev, cur, 1)[0]) > 10:
            continue  # keep the brute force (2^k subsets, in Python) quick
        g = blob_graph(prev, cur, margin=1, unmatched_cost=lam)
        assert g.n_greedy == 0
        assert g.cost == pytest.approx(_brute_force(prev, cur, lam, 1), abs=1e-9)
        _check_consistent(g, prev, cur, lam)
        n_cases += 1
        n_multi += len(g.merges) + len(g.splits) > 0
    assert n_multi > 20  # the cases exercise merges and splits, not only pairs


def test_greedy_fallback_gives_a_valid_graph() -> None:
    rng = np.random.default_rng(11)
    n_greedy = 0
    for _ in range(20):
        prev, cur = _random_scene(rng, 6, 6)
        k = len(candidate_edges(prev, cur, 2)[0])
        g = blob_graph(prev, cur, max_exact_edges=4)
        n_greedy += g.n_greedy
        _check_consistent(g, prev, cur)
        # never worse than leaving everything unmatched
        assert g.cost <= 0.5 * (sum(b.area for b in prev) + sum(b.area for b in cur)) + 1e-9
        if k <= 12:
            assert g.cost >= blob_graph(prev, cur).cost - 1e-9  # the exact one is a lower bound
    assert n_greedy >= 10


def test_crowd_blob_uses_greedy_and_stays_valid() -> None:
    prev = [mk(40 * k, 0, 40 * k + 30, 100, area=2000) for k in range(16)]
    cur = [mk(0, 0, 640, 100, area=31000)]  # one blob over everything: 16 candidate edges
    g = blob_graph(prev, cur)
    assert g.n_greedy == 1
    _check_consistent(g, prev, cur)
    assert g.merges and len(g.merges[0][0]) >= 15  # most of the walkers joined the crowd


def test_bad_options() -> None:
    with pytest.raises(ValueError, match="margin"):
        blob_graph([], [], margin=-1)
    assert graph_cost([mk(0, 0, 2, 2)], [mk(0, 0, 2, 2)] * 2, [(0, 0), (0, 1)]) == 4.0
    p2 = [mk(0, 0, 2, 2)] * 2
    assert graph_cost(p2, p2, [(0, 0), (0, 1), (1, 1)]) == float("inf")
