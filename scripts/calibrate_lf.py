"""`python scripts/calibrate_lf.py ...` runs `python -m experiments.calibrate_lf ...` (the README's command)."""
import runpy

runpy.run_module("experiments.calibrate_lf", run_name="__main__", alter_sys=True)
