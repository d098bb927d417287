"""`python scripts/bench_step.py ...` runs `python -m bench.step ...` (the README's command)."""
import runpy

runpy.run_module("bench.step", run_name="__main__", alter_sys=True)
