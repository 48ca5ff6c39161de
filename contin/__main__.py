"""``python -m contin`` is the ``contin`` command."""

import sys

from contin.cli import main

sys.exit(main())
