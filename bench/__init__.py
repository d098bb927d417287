"""``petswarm bench``: how fast is the environment, and what does a step cost?

All measurements run in one command on one machine, one after the other:

* **petswarm** ``env.step`` rate for 1 master + 2, 5 and 9 slaves, with the scripted
  leader–follower policy and with uniform random actions. Only ``env.step`` is timed; the policy's
  time and ``reset`` (which runs the join protocol on the clock) are timed and reported apart.
* **physics floor**: the same pymunk bodies as the env (the env's own :class:`World` with its
  robots, the kinematic user and the arena walls) stepped ``physics_substeps`` times per control
  step, setting every body's velocity before each substep as ``Robot.apply`` does, and nothing else:
  no clock, no radio, no observations.
* **peer**: PettingZoo MPE ``simple_spread`` (package ``mpe2``, optional ``bench`` extra) with as
  many agents as petswarm has robots, random continuous actions, ``parallel_env``.
* **breakdown** of a 5-slave step (physics, radio + middleware, user sensing, control,
  observation, reward + metrics, other) two ways: cProfile self times (:func:`breakdown_from_stats`)
  and a statistical stack sampler (:class:`StackSampler`, SIGPROF on CPU time), which has no
  per-call cost and so does not inflate call-heavy Python code.
* **memory**: tracemalloc and RSS of a long 5-slave run (resets as episodes end), in a fresh process.
* **training throughput**: SB3 PPO samples/s through the training vector env, in-process and with
  two worker processes.

The rooms: :mod:`petswarm.bench.settings` (how long, the targets), :mod:`petswarm.bench.loops` (the timed step
loops), :mod:`petswarm.bench.speed` (petswarm, the physics floor, MPE, side by side), :mod:`petswarm.bench.parts`
and :mod:`petswarm.bench.profile` (the step's breakdown), :mod:`petswarm.bench.memory`, :mod:`petswarm.bench.throughput`
(training), :mod:`petswarm.bench.machine`, :mod:`petswarm.bench.run` (``run_bench``, ``main_bench``: it all, the
JSON), :mod:`petswarm.bench.console` (the console text) and :mod:`petswarm.bench.page` (``docs/benchmarks.md`` and
its plot). ``python -m petswarm.bench.step`` times the default env's step alone.
"""
