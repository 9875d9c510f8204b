"""``python -m uuvid``: the same command line as the ``uuvid`` console script."""

from uuvid.cli.app import main

if __name__ == "__main__":
    main()
