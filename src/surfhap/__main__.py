"""``python -m surfhap``: the same command line as the ``surfhap`` script."""

import sys

from surfhap.cli import main

if __name__ == "__main__":
    sys.exit(main())
