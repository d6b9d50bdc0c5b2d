"""`python -m app`: the command line. A spawned worker process imports this module too (as
`__mp_main__`): it ignores Ctrl+C from birth (the studio stops its workers itself; a worker
interrupted while it started printed its own traceback and Dask's "Nanny failed to start").
Ctrl+C while the command starts is one line, even when a library swallowed the interrupt
(app.interrupts)."""

import signal
import sys

if __name__ == "__mp_main__":  # a worker process spawned by the studio or a command
    signal.signal(signal.SIGINT, signal.SIG_IGN)
else:
    from app import interrupts

    interrupts.install()
    try:
        from app.cli import main

        interrupts.stop_if_interrupted()
    except BaseException:  # an import that turned the interrupt into its own error (numpy)
        if not interrupts.interrupted():
            raise
        print("biped-studio: stopped (Ctrl+C) while starting", file=sys.stderr)
        sys.exit(130)

if __name__ == "__main__":  # the solver worker is spawned: it must not run the CLI again
    sys.exit(main())
