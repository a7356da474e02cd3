"""`python -m cvtdesign`: the same as the `cvtdesign` command."""
import sys

from cvtdesign.cli import main

sys.exit(main())
