import sys

from app.cli import main

if __name__ == "__main__":  # the solver worker is spawned: it must not run the CLI again
    sys.exit(main())
