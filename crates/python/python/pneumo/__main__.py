"""``python -m pneumo ARGS``: the ``pneumo`` command line (the same program as
the binary built by cargo): ``python -m pneumo sweep M.json --vary ...``."""

import signal
import sys

from . import main

if __name__ == "__main__":
    # behave as the binary: Ctrl-C ends the process, a closed pipe ends it quietly
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    if hasattr(signal, "SIGPIPE"):
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    sys.exit(main())
