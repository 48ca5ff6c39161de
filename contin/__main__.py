"""``python -m contin`` is the ``contin`` command."""

import sys

from contin.app.cli import main

if __name__ == "__main__":  # not when a worker process of a local Dask cluster imports the main module
    sys.exit(main())
