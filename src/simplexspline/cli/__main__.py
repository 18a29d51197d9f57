"""``python -m simplexspline.cli``: the same as the ``simplexspline`` command."""

import sys

from simplexspline.cli import main

sys.exit(main())
