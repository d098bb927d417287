"""`python scripts/measure_wearables.py ...` runs `python -m experiments.measure_wearables ...` (the README's command)."""
import runpy

runpy.run_module("experiments.measure_wearables", run_name="__main__", alter_sys=True)
