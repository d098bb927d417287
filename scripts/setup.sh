#!/usr/bin/env bash
# Set up a virtual environment in .venv with petswarm installed (editable).
#   bash scripts/setup.sh          # run + render
#   bash scripts/setup.sh test     # + training stack + test tools (torch==2.13.0 CPU first)
#   bash scripts/setup.sh train    # + training stack (pins the CPU build of torch first)
set -euo pipefail
cd "$(dirname "$0")/.."
what="${1:-run}"
[ -x .venv/bin/python ] || python3 -m venv .venv
py=.venv/bin/python
"$py" -m pip install -q --upgrade pip
case "$what" in
  run)   extras="render" ;;
  test)  "$py" -m pip install -q torch==2.13.0  # the CPU build on this machine's disk; never an unpinned torch
         extras="render,train,test" ;;
  train) "$py" -m pip install -q torch==2.13.0
         extras="render,train" ;;
  *) echo "setup.sh: unknown target '$what' (run | test | train)" >&2; exit 2 ;;
esac
"$py" -m pip install -q -e ".[$extras]"
"$py" -c "import petswarm_env" && echo "petswarm installed in .venv ($what)"
