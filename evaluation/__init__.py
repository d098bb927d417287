"""Evaluation: run and evaluate slave policies (runner, evaluate), statistics, and the HTML comparison report."""
