import sys

from corr_cad.run.cli import main

sys.exit(main())
