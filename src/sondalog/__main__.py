"""``python -m sondalog``: the ``sondalog`` command line."""

from sondalog.cli.main import main

if __name__ == "__main__":
    main()
