"""The `petswarm` command line (cli/main.py)."""
