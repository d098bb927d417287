"""Formation shapes as neighbour tables (seed 000 §3.5, Fig. 10; SPEC §3.5)."""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.config import ConfigError, load_config
from petswarm_env.middleware.formation import MAX_LINKS, build_formation, formation_for_mode, leading_user, table_for_members

C30, S30 = math.cos(math.radians(30)), math.sin(math.radians(30))

# formation frame: x along the swarm heading, y to the left; master (member 0) at the origin
EXPECTED_SLOTS = {
    "column": [(0, 0), (-1, 0), (-2, 0), (-3, 0), (-4, 0)],
    "row": [(0, 0), (0, 1), (0, -1), (0, 2), (0, -2)],
    "wedge": [(0, 0), (-C30, S30), (-C30, -S30), (-2 * C30, 2 * S30), (-2 * C30, -2 * S30)],
    "grid": [(0, 0), (0, -1), (-1, 0), (-1, -1), (-2, 0)],
}
SHAPES = list(EXPECTED_SLOTS)


def swarm_cfg(**overrides):
    return load_config(overrides={f"swarm.{k}": v for k, v in overrides.items()}).swarm


def formation(shape, n=5, spacing=1.0):
    return build_formation(swarm_cfg(formation=shape, spacing_m=spacing), n)


def path_to_master(f, member):
    """Follow the first reference link of each robot; return the chain of members to 0."""
    seen = [member]
    while seen[-1] != 0:
        nxt = f.links[seen[-1]][0].neighbour
        assert nxt not in seen, f"cycle in links: {seen + [nxt]}"
        seen.append(nxt)
    return seen


@pytest.mark.parametrize("shape", SHAPES)
def test_slot_positions(shape):
    f = formation(shape)
    assert f.size == 5
    assert f.shape == shape
    np.testing.assert_allclose(f.slot_positions(), np.array(EXPECTED_SLOTS[shape], float), atol=1e-12)


@pytest.mark.parametrize("shape", SHAPES)
def test_slot_positions_solved_once_give_a_new_array_each_call(shape):
    import copy
    import pickle
    f = formation(shape)
    first = f.slot_positions()
    assert np.array_equal(first, f._solve_slots())
    first += 100.0  # a caller that changes its copy changes no later answer
    again = f.slot_positions()
    assert again is not first and np.array_equal(again, f._solve_slots())
    for twin in (copy.deepcopy(f), pickle.loads(pickle.dumps(f))):
        assert twin == f and np.array_equal(twin.slot_positions(), again)
    assert np.array_equal(f.rotated(0.3).slot_positions(), f.rotated(0.3)._solve_slots())


def test_wedge_robot_1_behind_left_of_master():
    slots = formation("wedge").slot_positions()
    assert slots[1] == pytest.approx((-0.866, 0.5), abs=1e-3)
    assert slots[1][0] < 0 and slots[1][1] > 0  # behind, left
    assert slots[2][0] < 0 and slots[2][1] < 0  # behind, right


@pytest.mark.parametrize("shape", SHAPES)
def test_slots_scale_with_spacing(shape):
    np.testing.assert_allclose(
        formation(shape, spacing=1.7).slot_positions(), 1.7 * formation(shape).slot_positions(), atol=1e-12
    )


@pytest.mark.parametrize("shape", SHAPES)
def test_every_member_reachable_and_slots_distinct(shape):
    f = formation(shape)
    assert set(f.links) == {1, 2, 3, 4}
    for m in range(1, 5):
        assert 1 <= len(f.links[m]) <= MAX_LINKS
        assert path_to_master(f, m)[-1] == 0
    slots = f.slot_positions()
    d = np.hypot(*(slots[:, None, :] - slots[None, :, :]).transpose(2, 0, 1))
    assert d[~np.eye(5, dtype=bool)].min() >= 1.0 - 1e-9  # no two robots share a slot


@pytest.mark.parametrize("shape", SHAPES)
def test_each_link_offset_is_one_spacing(shape):
    f = formation(shape, spacing=1.3)
    for links in f.links.values():
        for lk in links:
            assert math.hypot(*lk.offset_m) == pytest.approx(1.3)


@pytest.mark.parametrize("shape", SHAPES)
def test_neighbours_symmetric(shape):
    f = formation(shape)
    for m in range(5):
        nb = f.neighbours(m)
        assert m not in nb
        assert nb, f"member {m} has no neighbour"
        for k in nb:
            assert m in f.neighbours(k)
    # every reference link is a neighbour relation
    for m, links in f.links.items():
        for lk in links:
            assert lk.neighbour in f.neighbours(m)


def test_neighbours_of_wedge():
    f = formation("wedge")
    assert f.neighbours(0) == {1, 2}
    assert f.neighbours(1) == {0, 3}
    assert f.neighbours(4) == {2}


def test_a_large_wedge_fills_its_v_row_by_row():
    """1 + 16: the V of 1 + 4 first, then the free places nearest the master; every slave 1 m from
    each of its one or two reference neighbours diagonally in front of it (an edge place of the V
    beyond the first two rows: the one in front and the one beside it, inward), 5 rows, 4.3 m deep."""
    f = formation("wedge", n=17)
    slots = f.slot_positions()
    assert np.allclose(slots[:5], EXPECTED_SLOTS["wedge"])
    assert np.allclose(slots[5], (-2 * C30, 0.0))  # the first inner place: between members 1 and 2, behind them
    assert slots[:, 0].min() == pytest.approx(-5 * C30)
    assert np.hypot(*slots.T).max() < 4.4  # two 8-robot arms reached 8 m
    for m, links in f.links.items():
        assert 1 <= len(links) <= MAX_LINKS
        for lk in links:
            assert lk.neighbour < m and slots[lk.neighbour][0] >= slots[m][0] - 1e-9  # in front of it or beside it
            assert math.dist(slots[m], slots[lk.neighbour]) == pytest.approx(1.0)
    # one reference: the first row and members 3, 4 (the V of 1 + 4 stays as it was); every other place two
    assert sorted(m for m, lks in f.links.items() if len(lks) == 1) == [1, 2, 3, 4]
    assert [lk.neighbour for lk in f.links[8]] == [3, 6]  # the left edge of row 3: member 3 in front, member 6 beside it
    assert [lk.neighbour for lk in formation("wedge", n=5).links[3]] == [1]
    d = np.hypot(*(slots[:, None] - slots[None]).transpose(2, 0, 1))
    assert d[~np.eye(17, dtype=bool)].min() == pytest.approx(1.0)


def test_grid_uses_front_and_side_neighbour():
    f = formation("grid")
    assert {lk.neighbour for lk in f.links[3]} == {1, 2}


@pytest.mark.parametrize("shape", SHAPES)
def test_hierarchy_level_1_is_farthest_from_user(shape):
    f = formation(shape)
    slots = f.slot_positions()
    for user in [(1.0, 0.0), (float(slots[:, 0].min()) - 1.0, 0.0), (0.3, 2.5)]:
        levels = f.hierarchy_levels(user)
        assert sorted(levels.values()) == [1, 2, 3, 4, 5]
        dist = {m: math.dist(slots[m], user) for m in range(5)}
        by_level = sorted(range(5), key=lambda m: levels[m])
        # level 1 is (one of) the farthest, and levels count up toward the user
        assert dist[by_level[0]] == pytest.approx(max(dist.values()))
        assert all(dist[a] >= dist[b] - 1e-9 for a, b in zip(by_level, by_level[1:]))


def test_hierarchy_master_placement():
    f = formation("column")
    # following mode: user ahead of the master; master is closest -> highest level
    assert f.hierarchy_levels((1.0, 0.0)) == {4: 1, 3: 2, 2: 3, 1: 4, 0: 5}
    # leading mode: user behind the formation; master is farthest -> level 1
    assert f.hierarchy_levels((-5.0, 0.0))[0] == 1


def test_formation_scales_to_other_sizes():
    for shape in SHAPES:
        for n in (1, 2, 3, 6, 9):
            f = formation(shape, n=n)
            assert f.size == n
            assert len(f.slot_positions()) == n


# -- custom neighbour tables ----------------------------------------------------------------------

CUSTOM = [
    {"robot": 1, "neighbour": 0, "offset_m": [-1.0, 0.5]},
    {"robot": 2, "neighbour": 1, "offset_m": [-1.0, 0.0]},
    {"robot": 3, "neighbour": 1, "offset_m": [0.0, -1.0]},
    {"robot": 3, "neighbour": 2, "offset_m": [1.0, -1.0]},
]


def custom_cfg(links):
    slaves = max(lk["robot"] for lk in links)  # the table's own slave count (the config refuses another)
    return load_config(overrides={"swarm.formation": "custom", "swarm.custom_links": links, "swarm.num_slaves": slaves}).swarm


def test_custom_links_from_config():
    f = build_formation(custom_cfg(CUSTOM), 4)
    assert f.shape == "custom"
    np.testing.assert_allclose(f.slot_positions(), [(0, 0), (-1, 0.5), (-2, 0.5), (-1, -0.5)])
    assert {lk.neighbour for lk in f.links[3]} == {1, 2}
    assert f.neighbours(1) == {0, 2, 3}


def test_custom_formation_through_the_env():
    env = petswarm_env.parallel_env(
        **{"swarm.formation": "custom", "swarm.custom_links": CUSTOM[:3], "swarm.num_slaves": 3}
    )
    env.reset(seed=0)
    assert env.episode.swarm.formation.shape == "custom"
    np.testing.assert_allclose(env.episode.swarm.formation.slot_positions()[2], (-2.0, 0.5))
    for n in env.episode.swarm.slave_ids():
        assert env.episode.swarm.nodes[n].formation.links == env.episode.swarm.formation.links


def test_fewer_members_than_the_custom_table_keep_the_rows_of_those_that_joined():
    # a table for 3 slaves, 2 joined (radio loss, or the other swarm took a robot): rows 1 and 2 stay
    f = build_formation(custom_cfg(CUSTOM), 3)
    assert set(f.links) == {1, 2} and f.links[2] == build_formation(custom_cfg(CUSTOM), 4).links[2]
    np.testing.assert_allclose(f.slot_positions(), [(0, 0), (-1, 0.5), (-2, 0.5)])


def test_a_custom_table_that_cannot_be_cut_plainly_keeps_every_slot():
    # re-rooted at member 3 by a master change (modes.py, succession.py), the table's member 2 follows member 3;
    # its swarm, down to three members, refills them: member 2 keeps its slot, now referred to member 1 (member 3's
    # reference); the plain cut raised inside the simulation clock (a training run's refill)
    wedge = [{"robot": 1, "neighbour": 0, "offset_m": [-1.0, 1.0]}, {"robot": 2, "neighbour": 0, "offset_m": [-1.0, -1.0]},
             {"robot": 3, "neighbour": 1, "offset_m": [-1.0, 0.0]}]
    table, _ = build_formation(custom_cfg(wedge), 4).rerooted(3)
    assert [lk.neighbour for lk in table.links[2]] == [3] and [lk.neighbour for lk in table.links[3]] == [1]
    links = [{"robot": m, "neighbour": lk.neighbour, "offset_m": list(lk.offset_m)}
             for m, lks in table.links.items() for lk in lks]
    cfg = custom_cfg(links)
    with pytest.raises(ValueError, match=r"members \[1, 2\], got \[1\]"):
        formation_for_mode(cfg, 3, "following")
    whole = formation_for_mode(cfg, 4, "following")
    cut = table_for_members(cfg, range(3), "following")
    assert cut.size == 3 and cut.links[1] == whole.links[1] and [lk.neighbour for lk in cut.links[2]] == [1]
    np.testing.assert_allclose(cut.slot_positions(), whole.slot_positions()[:3], atol=1e-9)
    assert table_for_members(cfg, [0, 1], "following").links == {1: whole.links[1]}
    # numbers with a gap (the lost master's slot a master change leaves open): the whole table, the open row open
    assert table_for_members(cfg, [0, 2, 3], "following").links == whole.links
    for mode in ("following", "leading"):  # a table that can be cut is cut as before
        user = leading_user(load_config()) if mode == "leading" else None
        plain = formation_for_mode(custom_cfg(CUSTOM), 3, mode, user)
        assert table_for_members(custom_cfg(CUSTOM), range(3), mode, user).links == plain.links
    with pytest.raises(ValueError):  # more members than the table: still an error
        table_for_members(cfg, range(5), "following")


def test_an_open_member_number_is_referred_through():
    from petswarm_env.references import _held_link

    table = build_formation(custom_cfg([{"robot": 1, "neighbour": 0, "offset_m": [-1.0, 0.0]},
                                        {"robot": 2, "neighbour": 1, "offset_m": [0.0, 1.0]}]), 3)
    assert _held_link(table, {0: 7, 1: 8, 2: 9}, table.links[2][0]) == (8, 0.0, 1.0)
    assert _held_link(table, {0: 7, 2: 9}, table.links[2][0]) == (7, -1.0, 1.0)  # member 1 open: through its link to 0
    assert _held_link(table, {2: 9}, table.links[2][0]) is None


def test_a_swarm_on_a_table_that_cannot_be_cut_outlives_its_master_and_refills():
    # a written table whose member 2 refers to member 3; the master dies, a robot arrives: the successor's table leaves
    # the lost master's slot open, the refill numbers the recruit past it (the metrics raised a KeyError, before that
    # the refill's plain cut a ValueError)
    links = [{"robot": 1, "neighbour": 0, "offset_m": [-1.0, 0.0]}, {"robot": 2, "neighbour": 3, "offset_m": [0.0, 1.0]},
             {"robot": 3, "neighbour": 1, "offset_m": [-1.0, 0.0]}]
    env = petswarm_env.parallel_env(**{
        "max_cycles": 500, "swarm.formation": "custom", "swarm.custom_links": links, "swarm.num_slaves": 3,
        "faults": [{"at_s": 12.0, "robot": "master", "kind": "dead"}], "swarm.extra_robots": 2,
        "swarm.assignment": "ruta_centralized", "arrivals": [{"at_s": 15.0, "type": "petbot"}]})
    obs, _ = env.reset(seed=273216)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=0)
    steps = 0
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        steps += 1
    swarm = env.episode.truth.swarms[0]
    members = dict(swarm.master.know.members)
    assert steps == 500 and swarm.master.node_id != 0 and sorted(members) != list(range(len(members)))
    assert set(members) <= set(range(swarm.formation.size))  # every member has its row


def test_a_custom_table_for_another_slave_count_is_refused_at_load():
    with pytest.raises(ConfigError, match=r"names members \[1, 2, 3\] but swarm.num_slaves=4 .* set swarm.num_slaves=3"):
        load_config(overrides={"swarm.formation": "custom", "swarm.custom_links": CUSTOM, "swarm.num_slaves": 4})


def test_custom_without_links_is_refused():
    with pytest.raises(ConfigError, match="swarm.custom_links"):
        load_config(overrides={"swarm.formation": "custom"})


@pytest.mark.parametrize(
    "links, n, match",
    [
        (CUSTOM[:2], 4, r"members \[1, 2, 3\]"),  # member 3 has no link
        # fewer joined than the table names, and the member that joined is linked only to one that did not
        ([{"robot": 1, "neighbour": 2, "offset_m": [-1, 0]}, {"robot": 2, "neighbour": 0, "offset_m": [-1, 0]}], 2,
         r"got \[\] \(of a table for 2 members, 1 joined\)"),
        ([{"robot": 1, "neighbour": 1, "offset_m": [-1, 0]}], 2, "invalid neighbour 1"),  # self link
        ([{"robot": 1, "neighbour": 5, "offset_m": [-1, 0]}], 2, "invalid neighbour 5"),  # out of range
        (
            [
                {"robot": 1, "neighbour": 2, "offset_m": [-1, 0]},
                {"robot": 2, "neighbour": 1, "offset_m": [1, 0]},
            ],
            3,
            "do not reach the master",
        ),  # a cycle that never reaches member 0
        (
            [
                {"robot": 1, "neighbour": 0, "offset_m": [-1, 0]},
                {"robot": 2, "neighbour": 0, "offset_m": [0, 1]},
                {"robot": 3, "neighbour": 0, "offset_m": [0, -1]},
                {"robot": 3, "neighbour": 1, "offset_m": [1, -1]},
                {"robot": 3, "neighbour": 2, "offset_m": [0, -2]},
            ],
            4,
            "at most 2",
        ),  # too many links
    ],
)
def test_bad_custom_links_raise_clear_value_error(links, n, match):
    with pytest.raises(ValueError, match=match) as exc:
        build_formation(custom_cfg(links), n)
    assert "swarm.custom_links" in str(exc.value) or "formation links" in str(exc.value)


def test_bad_custom_links_refused_by_the_env():
    """Refused when the env is made (its observation bounds read the formation's table), before any reset."""
    with pytest.raises(ValueError, match="swarm.custom_links"):
        petswarm_env.parallel_env(**{"swarm.formation": "custom", "swarm.custom_links": CUSTOM[:2], "swarm.num_slaves": 3})


def test_custom_link_member_numbers_validated_by_config():
    with pytest.raises(ConfigError, match="robot"):
        load_config(overrides={"swarm.formation": "custom", "swarm.custom_links": [{"robot": 0, "neighbour": 0, "offset_m": [1, 0]}]})


@pytest.mark.parametrize("shape", ["wedge", "column", "grid", "row"])
def test_no_leading_slot_stands_on_the_user(shape):
    # seed 000 §3.5: leading, the formation lies between the master and the user as far as the LF
    # range allows; a deep table must not put a slot where the user stands
    from petswarm_env.middleware.formation import LEADING_CLEARANCE_M, formation_for_mode, leading_user
    from petswarm_env.middleware.master_role import master_distance_m

    for slaves in range(1, 17):
        cfg = load_config(overrides={"swarm.formation": shape, "swarm.num_slaves": slaves})
        f = formation_for_mode(cfg.swarm, slaves + 1, "leading", leading_user(cfg))
        slots = f.slot_positions()
        ux = master_distance_m(cfg, f, "leading")
        assert np.hypot(slots[1:, 0] - ux, slots[1:, 1]).min() >= LEADING_CLEARANCE_M - 1e-9, (shape, slaves)
        assert (slots[:, 0] >= -1e-9).all()  # still laid out toward the user, the master farthest back
        gaps = np.hypot(*(slots[:, None] - slots[None]).transpose(2, 0, 1)) + np.eye(len(slots)) * 9
        assert gaps.min() >= cfg.swarm.spacing_m - 1e-9  # no two slots nearer than a spacing


def test_leading_layouts_keep_the_turned_table_where_no_slot_is_near_the_user():
    from petswarm_env.middleware.formation import formation_for_mode, leading_user

    cfg = load_config()
    user = leading_user(cfg)
    for shape, slaves in [("wedge", 2), ("wedge", 4), ("row", 4), ("row", 9), ("grid", 1)]:
        c = load_config(overrides={"swarm.formation": shape, "swarm.num_slaves": slaves})
        assert formation_for_mode(c.swarm, slaves + 1, "leading", user).links == \
            build_formation(c.swarm, slaves + 1).rotated(math.pi).links
    # 1 + 5: row 2's centre (1.73 m out, the user at 1.7 m) stays free; member 5 takes row 3's left of centre
    c = load_config(overrides={"swarm.num_slaves": 5})
    slots = formation_for_mode(c.swarm, 6, "leading", user).slot_positions()
    np.testing.assert_allclose(slots[5], [3 * math.cos(math.radians(30)), -0.5], atol=1e-9)
    for shape in ("column", "grid", "wedge"):
        c = load_config(overrides={"swarm.formation": shape, "swarm.num_slaves": 6})
        assert formation_for_mode(c.swarm, 7, "following").links == build_formation(c.swarm, 7).links
    with pytest.raises(ValueError, match="leading_user"):
        formation_for_mode(cfg.swarm, 5, "leading")
