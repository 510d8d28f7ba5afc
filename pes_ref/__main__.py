"""``python -m pes_ref`` and the ``pes_ref`` console command: [`pes_ref.cli.main`][pes_ref.cli.main].

The command line is imported inside `run`, so that Ctrl-C while it is still being
imported ends as Ctrl-C does later: one line ``interrupted`` and exit status 130.
"""
import sys


def run() -> int:
    """Import the command line and run it on ``sys.argv``; return the exit status."""
    try:
        from pes_ref.core.runtime.signals import interrupted, note_interrupts   # the standard library only
        note_interrupts()
        try:
            from pes_ref.cli import main
        except Exception:
            if not interrupted():       # else Ctrl-C, which an import turned into another error
                raise
            raise KeyboardInterrupt from None
    except KeyboardInterrupt:
        from pes_ref.cli.common import EXIT_INTERRUPTED
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return main()


if __name__ == "__main__":
    sys.exit(run())
