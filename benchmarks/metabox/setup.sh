#!/usr/bin/env bash
# Optional: the separate MetaBox-v2 venv that benchmarks/metabox/run_metabox.py runs in.
# Never the project's .venv: metaevobox 2.0.2 brings numpy 1.26 (through tianshou) and ~3 GB of
# dependencies (ray, xgboost with nvidia-nccl-cu12, tensorboard, ...).
#
#   benchmarks/metabox/setup.sh [VENV]          (default VENV: ~/.venvs/metabox)
#
# Environment: PYTHON (>= 3.11.5, metaevobox's requires-python; default python3);
# TORCH_SPEC (default torch==2.13.0). torch is installed FIRST and then pinned, so metaevobox's
# dependencies (evox, tianshou) keep it: pick a CPU build (`pip install torch==X --index-url
# https://download.pytorch.org/whl/cpu` where no local wheel exists) or pip fetches a multi-GB
# CUDA build. Needs PyPI only: the agents' pretrained checkpoints ship inside the metaevobox
# package (metaevobox/model/bbob-10D/difficult/{RLDEAFL,GLEET,LDE}.pkl); nothing is downloaded
# at run time.
set -euo pipefail
VENV=${1:-$HOME/.venvs/metabox}
PYTHON=${PYTHON:-python3}
TORCH_SPEC=${TORCH_SPEC:-torch==2.13.0}
METAEVOBOX_SPEC=${METAEVOBOX_SPEC:-metaevobox==2.0.2}

"$PYTHON" -m venv "$VENV"
"$VENV/bin/pip" install "$TORCH_SPEC"
pins=$(mktemp)
trap 'rm -f "$pins"' EXIT
"$VENV/bin/pip" freeze | grep -i '^torch==' > "$pins"
"$VENV/bin/pip" install -c "$pins" "$METAEVOBOX_SPEC"
"$VENV/bin/python" - <<'EOF'
import importlib.resources as r
import numpy, torch
d = r.files("metaevobox").joinpath("model", "bbob-10D", "difficult")
missing = [s for s in ("RLDEAFL", "GLEET", "LDE") if not d.joinpath(f"{s}.pkl").is_file()]
if missing:
    raise SystemExit(f"metaevobox: checkpoints missing: {missing}")
print(f"ok: numpy {numpy.__version__}, torch {torch.__version__}, checkpoints in {d}")
EOF
