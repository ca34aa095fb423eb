"""Runs `python3 -m avacraft.bench` (see avacraft/bench.py) on the installed package."""

from avacraft.bench import main

if __name__ == "__main__":
    main()
