"""``python -m terrascape.bench NAME [--quick]`` — same as ``terrascape bench NAME``."""

from terrascape.cli import main

if __name__ == "__main__":
    import sys

    main(["bench", *sys.argv[1:]])
