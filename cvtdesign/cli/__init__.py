"""The command line: `parser` builds it and dispatches each command to its module here."""
from cvtdesign.cli.parser import main

__all__ = ["main"]
