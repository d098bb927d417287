"""`python scripts/calibrate_ir.py ...` runs `python -m experiments.calibrate_ir ...` (the README's command)."""
import runpy

runpy.run_module("experiments.calibrate_ir", run_name="__main__", alter_sys=True)
