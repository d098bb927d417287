"""Tests for petswarm_env.sim.geometry and the IR line of sight against hand-computed cases.

The per-circle ray cast (``ray_circle_distances``) and the many-segment line of sight
(``segments_blocked``) are the oracles of the shipped ``ring_first_hits`` and
``ir_channel.line_of_sight_blocked`` (tests/oracles.py); the hand cases check both forms."""

import math

import numpy as np
import pytest

from petswarm_env.comms.ir_channel import line_of_sight_blocked
from petswarm_env.sim.geometry import ray_segment_distances, ring_first_hits
from tests.oracles import ray_circle_distances, segments_blocked
from petswarm_env.comms.ir_channel import IRChannel, line_of_sight_blocked
from petswarm_env.sim import geometry
from tests import oracles


def _ring_one_circle(origin, angle, center, radius, max_range):
    """ring_first_hits for one ray against one circle (no walls)."""
    d = ring_first_hits(np.array([origin], float), np.array([0.0]), np.array([angle]), np.array([center], float),
                        np.array([radius], float), None, max_range)
    return float(d[0, 0])


def test_ray_circle_hand_cases():
    origins = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    dirs = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [np.sqrt(0.5), np.sqrt(0.5)]])
    centers = np.array([[5.0, 0.0], [0.0, 3.0]])
    radii = np.array([1.0, 0.5])
    d = ray_circle_distances(origins, dirs, centers, radii, max_range=10.0)
    assert d.shape == (4, 2)
    assert d[0, 0] == pytest.approx(4.0)  # straight at the first circle
    assert d[0, 1] == np.inf  # perpendicular to the second
    assert d[1, 0] == np.inf  # circle behind the ray
    assert d[2, 1] == pytest.approx(2.5)
    assert d[2, 0] == np.inf
    # 45° ray vs circle at (5, 0) r=1: closest approach 5/√2 ≈ 3.54 > 1 → miss
    assert d[3, 0] == np.inf
    angles = [0.0, math.pi, math.pi / 2, math.pi / 4]  # the same rays in the ring's form
    for i, a in enumerate(angles):
        for j in range(2):
            ring = _ring_one_circle(origins[i], a, centers[j], radii[j], 10.0)
            assert ring == pytest.approx(d[i, j], abs=1e-12) if np.isfinite(d[i, j]) else ring == np.inf


def test_ray_circle_tangent_and_oblique():
    # Ray along y = 1 grazes the unit circle at (5, 0): tangent hit at x = 5.
    d = ray_circle_distances([[0.0, 1.0]], [[1.0, 0.0]], [[5.0, 0.0]], [1.0], max_range=10.0)
    assert d[0, 0] == pytest.approx(5.0)
    # Ray along y = 0.6 hits the unit circle at x = 5 − 0.8.
    d = ray_circle_distances([[0.0, 0.6]], [[1.0, 0.0]], [[5.0, 0.0]], [1.0], max_range=10.0)
    assert d[0, 0] == pytest.approx(4.2)
    assert _ring_one_circle((0.0, 1.0), 0.0, (5.0, 0.0), 1.0, 10.0) == pytest.approx(5.0)
    assert _ring_one_circle((0.0, 0.6), 0.0, (5.0, 0.0), 1.0, 10.0) == pytest.approx(4.2)


def test_ray_circle_max_range_and_origin_inside():
    d = ray_circle_distances([[0.0, 0.0]], [[1.0, 0.0]], [[5.0, 0.0]], [1.0], max_range=3.9)
    assert d[0, 0] == np.inf
    # Origin inside its own body: that circle is ignored, the other one is still seen.
    d = ray_circle_distances([[0.0, 0.0]], [[1.0, 0.0]], [[0.0, 0.0], [2.0, 0.0]], [0.3, 0.5], max_range=10.0)
    assert d[0, 0] == np.inf
    assert d[0, 1] == pytest.approx(1.5)
    assert _ring_one_circle((0.0, 0.0), 0.0, (5.0, 0.0), 1.0, 3.9) == np.inf
    assert _ring_one_circle((0.0, 0.0), 0.0, (0.0, 0.0), 0.3, 10.0) == np.inf


def test_ray_segment_hand_cases():
    origins = np.zeros((4, 2))
    dirs = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5)]])
    seg_a = np.array([[3.0, -1.0], [-1.0, 2.0], [2.0, 0.0]])
    seg_b = np.array([[3.0, 1.0], [1.0, 2.0], [0.0, 2.0]])
    d = ray_segment_distances(origins, dirs, seg_a, seg_b, max_range=10.0)
    assert d.shape == (4, 3)
    assert d[0, 0] == pytest.approx(3.0)
    assert d[0, 1] == np.inf  # parallel to the horizontal segment
    assert d[0, 2] == pytest.approx(2.0)  # diagonal segment's end point (2, 0)
    assert d[1, 1] == pytest.approx(2.0)
    assert d[1, 0] == np.inf  # parallel to the vertical segment
    assert np.all(d[2] == np.inf)  # everything is behind the ray
    assert d[3, 2] == pytest.approx(np.sqrt(2.0))  # hits the diagonal at (1, 1)
    assert d[3, 0] == np.inf  # would cross x = 3 at y = 3, beyond the segment
    assert d[3, 1] == np.inf  # would cross y = 2 at x = 2, beyond the segment


def test_ray_segment_misses_beyond_end_and_range():
    d = ray_segment_distances([[0.0, 5.0]], [[1.0, 0.0]], [[3.0, -1.0]], [[3.0, 1.0]], max_range=10.0)
    assert d[0, 0] == np.inf
    d = ray_segment_distances([[0.0, 0.0]], [[1.0, 0.0]], [[3.0, -1.0]], [[3.0, 1.0]], max_range=2.5)
    assert d[0, 0] == np.inf
    # End point counts as a hit.
    d = ray_segment_distances([[0.0, 1.0]], [[1.0, 0.0]], [[3.0, -1.0]], [[3.0, 1.0]], max_range=10.0)
    assert d[0, 0] == pytest.approx(3.0)


def test_empty_inputs():
    origins = np.zeros((3, 2))
    dirs = np.tile([1.0, 0.0], (3, 1))
    assert ray_circle_distances(origins, dirs, np.zeros((0, 2)), np.zeros(0), 5.0).shape == (3, 0)
    assert ray_segment_distances(origins, dirs, np.zeros((0, 2)), np.zeros((0, 2)), 5.0).shape == (3, 0)
    assert ray_circle_distances(np.zeros((0, 2)), np.zeros((0, 2)), [[1.0, 0.0]], [0.5], 5.0).shape == (0, 1)
    blocked = segments_blocked(origins, origins + 1.0, np.zeros((0, 2)), np.zeros(0), np.zeros((3, 0), bool))
    assert blocked.shape == (3,)
    assert not blocked.any()
    assert segments_blocked(np.zeros((0, 2)), np.zeros((0, 2)), [[0.0, 0.0]], [1.0], np.zeros((0, 1), bool)).shape == (
        0,
    )


def test_segments_blocked_with_exclude():
    # Three robots on a line: A(0,0), B(1,0), C(2,0), radius 0.2; plus one off-line body D(1,1).
    centers = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.0, 1.0]])
    radii = np.full(4, 0.2)
    p_from = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    p_to = np.array([[2.0, 0.0], [1.0, 0.0], [2.0, 2.0]])
    exclude = np.zeros((3, 4), bool)
    exclude[0, [0, 2]] = True  # A → C: B sits in between
    exclude[1, [0, 1]] = True  # A → B: nothing in between
    exclude[2, [0]] = True  # A → (2,2): passes through D at (1,1)
    blocked = segments_blocked(p_from, p_to, centers, radii, exclude)
    np.testing.assert_array_equal(blocked, [True, False, True])
    # Excluding the blocker clears the line of sight.
    exclude[0, 1] = True
    exclude[2, 3] = True
    np.testing.assert_array_equal(segments_blocked(p_from, p_to, centers, radii, exclude), [False, False, False])
    # the IR slot's form: the receiver and the transmitter are the two excluded bodies
    cl, rl = centers.tolist() + [[2.0, 2.0]], radii.tolist() + [0.2]
    assert line_of_sight_blocked(0.0, 0.0, 2.0, 0.0, cl, rl, 0, 2)  # A → C: B in between
    assert not line_of_sight_blocked(0.0, 0.0, 1.0, 0.0, cl, rl, 0, 1)  # A → B
    assert line_of_sight_blocked(0.0, 0.0, 2.0, 2.0, cl, rl, 0, 4)  # A → (2, 2): through D


def test_segments_blocked_near_miss_and_beyond_end():
    centers = np.array([[1.0, 0.25], [3.0, 0.0]])
    radii = np.array([0.2, 0.5])
    # Body 0.25 m off the segment with radius 0.2: clear. Body beyond the segment end: clear.
    blocked = segments_blocked([[0.0, 0.0]], [[2.0, 0.0]], centers, radii, np.zeros((1, 2), bool))
    assert not blocked[0]
    blocked = segments_blocked([[0.0, 0.0]], [[2.6, 0.0]], centers, radii, np.zeros((1, 2), bool))
    assert blocked[0]
    cl, rl = centers.tolist() + [[0.0, 0.0]], radii.tolist() + [0.1]  # the receiver at the origin
    assert not line_of_sight_blocked(0.0, 0.0, 2.0, 0.0, cl, rl, 2, 2)
    assert line_of_sight_blocked(0.0, 0.0, 2.6, 0.0, cl, rl, 2, 2)


def test_wrap_angle_on_floats_and_arrays_alike():
    """The one angle wrap: [−π, π), the same numbers on Python floats and on numpy arrays, and
    −wrap_angle(−a) is π − (π − a) mod 2π (the IR estimator's (−π, π]) to the bit."""
    from petswarm_env.sim.geometry import wrap_angle

    rng = np.random.default_rng(4)
    a = np.concatenate([rng.uniform(-20.0, 20.0, 20_000), [0.0, math.pi, -math.pi, 3 * math.pi, 1e-300]])
    got = np.array([wrap_angle(x) for x in a.tolist()])
    assert np.array_equal(got.view(np.uint64), wrap_angle(a).view(np.uint64))
    assert ((got >= -math.pi) & (got <= math.pi)).all()
    np.testing.assert_allclose(np.cos(got), np.cos(a), atol=1e-12)
    mirrored = [-wrap_angle(-x) for x in a.tolist()]
    assert mirrored == [math.pi - (math.pi - x) % (2 * math.pi) for x in a.tolist()]
    assert wrap_angle(math.pi) == -math.pi and -wrap_angle(-math.pi) == math.pi


def _scene(rng, n_robots, n_other):
    centers = rng.uniform(-3.0, 3.0, (n_robots + n_other, 2))
    radii = rng.uniform(0.1, 0.4, n_robots + n_other)
    headings = rng.uniform(-math.pi, math.pi, n_robots)
    return centers, radii, headings


@pytest.mark.parametrize("seed", range(20))
def test_ring_first_hits_equals_ray_casts_against_circles_and_segments(seed):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(1, 8)), int(rng.integers(1, 13))
    centers, radii, headings = _scene(rng, n, int(rng.integers(0, 3)))
    seg_a = rng.uniform(-4.0, 4.0, (int(rng.integers(0, 6)), 2))
    seg_b = seg_a + rng.uniform(-3.0, 3.0, seg_a.shape)
    reach = float(rng.uniform(0.5, 3.0))
    angles = np.arange(k) * (2 * math.pi / k)
    got = geometry.ring_first_hits(centers[:n], headings, angles, centers, radii, geometry.SegmentSet(seg_a, seg_b, reach), reach)
    ang = headings[:, None] + angles[None, :]
    dirs = np.stack([np.cos(ang), np.sin(ang)], axis=-1).reshape(-1, 2)
    origins = np.repeat(centers[:n], k, axis=0)
    want = oracles.ray_circle_distances(origins, dirs, centers, radii, reach).min(axis=1)
    if len(seg_a):
        want = np.minimum(want, geometry.ray_segment_distances(origins, dirs, seg_a, seg_b, reach).min(axis=1))
    want = want.reshape(n, k)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    assert np.isfinite(want).any() or seed > 0  # the scenes do produce hits
    np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(10))
def test_ring_first_hits_equals_the_masked_formulation_bit_for_bit(seed):
    """Crowded scenes (touching and overlapping bodies, walls close by, origins inside other
    bodies): every distance equal to the bit, misses and the range cut included."""
    rng = np.random.default_rng(500 + seed)
    hits = 0
    for _ in range(200):
        n, k = int(rng.integers(1, 10)), int(rng.choice([1, 4, 8, 12]))
        centers = rng.uniform(-1.5, 1.5, (n + int(rng.integers(0, 3)), 2))
        radii = rng.uniform(0.1, 0.4, len(centers))
        headings = rng.uniform(-4.0, 4.0, n)
        seg_a = rng.uniform(-3.0, 3.0, (int(rng.integers(0, 4)), 2))
        seg_b = seg_a + rng.uniform(-3.0, 3.0, seg_a.shape)
        reach = float(rng.uniform(0.3, 2.5))
        angles = np.arange(k) * (2 * math.pi / k)
        want = oracles.ring_first_hits_masked(centers[:n], headings, angles, centers, radii, seg_a, seg_b, reach)
        got = geometry.ring_first_hits(centers[:n], headings, angles, centers, radii,
                                       geometry.SegmentSet(seg_a, seg_b, reach), reach)
        assert got.shape == want.shape and np.array_equal(got, want)
        hits += int(np.isfinite(want).sum())
    assert hits > 1000


def test_segments_out_of_reach_are_left_out_but_near_ones_are_hit():
    walls = geometry.SegmentSet(np.array([[5.0, -1.0], [-50.0, -1.0]]), np.array([[5.0, 1.0], [-50.0, 1.0]]), 2.0)
    assert walls.near(np.array([[0.0, 0.0]])) == []
    assert walls.near(np.array([[3.5, 0.0]])) == [0]
    d = geometry.ring_first_hits(np.array([[3.5, 0.0]]), np.array([0.0]), np.array([0.0, math.pi]), np.zeros((0, 2)),
                                 np.zeros(0), walls, 2.0)
    assert d[0, 0] == pytest.approx(1.5) and d[0, 1] == np.inf


@pytest.mark.parametrize("seed", range(20))
def test_ir_line_of_sight_equals_segments_blocked(seed):
    rng = np.random.default_rng(100 + seed)
    centers, radii, _ = _scene(rng, 8, 2)
    tx = int(rng.integers(8))
    rx = np.array([i for i in range(8) if i != tx and rng.random() < 0.8] or [(tx + 1) % 8])
    exclude = np.zeros((len(rx), len(centers)), bool)
    exclude[np.arange(len(rx)), rx] = True
    exclude[:, tx] = True
    want = oracles.segments_blocked(centers[rx], np.broadcast_to(centers[tx], (len(rx), 2)), centers, radii, exclude)
    cl, rl = centers.tolist(), radii.tolist()
    got = np.array([line_of_sight_blocked(*centers[r], *(centers[tx] - centers[r]), cl, rl, int(r), tx) for r in rx])
    assert np.array_equal(got, want)


def test_segment_crosses_hand_cases():
    """A proper crossing blocks; touching an end point, grazing, parallel and collinear lines do not."""
    from petswarm_env.sim.geometry import segment_crosses

    assert segment_crosses(0.0, 0.0, 2.0, 0.0, 1.0, -1.0, 1.0, 1.0)  # a cross
    assert not segment_crosses(0.0, 0.0, 2.0, 0.0, 3.0, -1.0, 3.0, 1.0)  # beyond the end
    assert not segment_crosses(0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 1.0, 1.0)  # the wall's end point on the line
    assert not segment_crosses(0.0, 0.0, 2.0, 0.0, 2.0, -1.0, 2.0, 1.0)  # the line ends on the wall
    assert not segment_crosses(0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 2.0, 1.0)  # parallel
    assert not segment_crosses(0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 3.0, 0.0)  # collinear overlap
    assert segment_crosses(0.0, 0.0, 2.0, 2.0, 0.0, 2.0, 2.0, 0.0)  # diagonals of a square
