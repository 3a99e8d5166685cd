"""python -m durer: the same as the `durer` command."""

import sys

from .cli import main

sys.exit(main())
