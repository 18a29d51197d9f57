"""``python -m simplexspline``: the same as the ``simplexspline`` command."""

import sys

from simplexspline.launcher import main

if __name__ == "__main__":
    sys.exit(main())
