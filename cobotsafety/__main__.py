import sys

from cobotsafety.cli import main

sys.exit(main())
