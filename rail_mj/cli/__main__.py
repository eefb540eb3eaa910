"""`python -m rail_mj.cli`: the `rail-mj` command."""

import sys

from rail_mj.cli.main import main

sys.exit(main())
