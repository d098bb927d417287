"""`python scripts/calibrate_organize.py ...` runs `python -m experiments.calibrate_organize ...` (the README's command)."""
import runpy

runpy.run_module("experiments.calibrate_organize", run_name="__main__", alter_sys=True)
