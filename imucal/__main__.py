"""The ``imucal`` command and ``python -m imucal``: the command line, Ctrl-C included."""

from .signals import finish, raise_on_signals, report


def run() -> None:
    """Console-script entry point: :func:`imucal.cli.main`, after loading it.

    Loading the command line (typer, click) takes the first 0.1-0.2 s; a Ctrl-C or
    SIGTERM then ends with the same line and status as later, not Python's traceback.

    Raises
    ------
    SystemExit
        with the command's exit status (docs/errors.md); also when Ctrl-C, SIGTERM or SIGHUP
        arrives while the command line loads.
    """
    raise_on_signals()
    try:
        from .cli import main
    except KeyboardInterrupt as err:
        raise SystemExit(report(err)) from None
    try:
        main()
    finally:
        finish()


if __name__ == "__main__":
    run()
