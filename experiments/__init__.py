"""The papers' experiments, reproduced in the simulation: one module per experiment, their registry and report (`petswarm reproduce`), and the calibrations (`python -m experiments.NAME`)."""
