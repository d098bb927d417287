"""experiments/measure_walks.py: a short walk is driven to its end; the row reads the session and the truth."""

from petswarm.experiments import measure_walks


def test_a_short_following_walk_is_driven_to_its_end():
    r = measure_walks.run("straight", 0, "following", 150, {})
    assert r["driven"] and r["state"] == "following" and r["distance_m"] <= measure_walks.DRIVING_M
    assert r["emergency_s"] == 0.0 and r["script_s"] > 0.0


def test_a_user_moved_out_of_reach_at_the_end_is_not_driven(monkeypatch):
    import petswarm_env

    made = petswarm_env.parallel_env

    def far_user(**kw):  # the user carried 6 m off just before the last step: the master stands beyond 2 m
        env = made(**kw)
        step = env.step

        def step_and_move(actions):
            if env.num_cycles == kw["max_cycles"] - 1:
                u = env.episode.world.user
                u.body.position = (u.position[0] + 6.0, u.position[1])
                env.episode.world.invalidate_truth()
            return step(actions)
        env.step = step_and_move
        return env
    monkeypatch.setattr(petswarm_env, "parallel_env", far_user)
    r = measure_walks.run("straight", 0, "following", 150, {})
    assert not r["driven"] and r["distance_m"] > measure_walks.DRIVING_M
