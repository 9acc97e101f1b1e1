"""``python -m clearance_pin``: the ``clearance-pin`` command (:mod:`clearance_pin.cli`)."""

import sys

from .cli import main

sys.exit(main())
