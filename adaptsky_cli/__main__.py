"""``python -m adaptsky_cli``: the ``adaptsky`` command where its console script is not
installed (a checkout on PYTHONPATH, as ``scripts/gpu_check.sh`` runs it)."""

import sys

from adaptsky_cli.cli.main import main

sys.exit(main(sys.argv[1:]))
