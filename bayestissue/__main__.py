"""``python -m bayestissue``: the command-line interface."""

import sys

from bayestissue.cli import main

sys.exit(main())
