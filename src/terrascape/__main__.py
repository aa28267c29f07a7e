"""``python -m terrascape ARGS`` — the same as ``terrascape ARGS``."""

from terrascape.cli import main

if __name__ == "__main__":
    main()
