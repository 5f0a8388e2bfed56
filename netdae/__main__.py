"""``python -m netdae``: the ``netdae`` command line (:mod:`netdae.cli`)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
