"""``python -m firenav_framework`` is the ``firenav`` command."""
import sys

from .cli import main

sys.exit(main())
