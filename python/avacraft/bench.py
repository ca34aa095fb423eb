"""Steps per second of the Python SMAC loop against the same loop in Rust, measured in one run.

    python3 -m avacraft.bench [--steps N] [--maps 3m_vlm 2s3z_vlm]

Each step of both loops: every agent's observation, the state, the action masks, a random
available action per agent, a checked step (and a reset when the episode ends). The ratio
Python/Rust shows what the facade costs; the goal is 0.5 or more. Timings are printed, never
asserted.
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import time

from . import StarCraft2Env
from ._avacraft import rust_loop_steps_per_s


def python_loop_steps_per_s(map_name: str, steps: int, seed: int = 0) -> float:
    env = StarCraft2Env(map_name=map_name, seed=seed)
    # The standard library's generator: numpy's per-call overhead on arrays this small would
    # cost more than the facade itself, and the point is to measure the facade.
    choice = random.Random(seed).choice
    env.reset()
    start = time.perf_counter()
    for _ in range(steps):
        env.get_obs()
        env.get_state()
        avail = env.get_avail_actions()
        actions = [choice([i for i, a in enumerate(m) if a]) for m in avail]
        _, terminated, _ = env.step(actions)
        if terminated:
            env.reset()
    return steps / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--maps", nargs="+", default=["3m_vlm", "2s3z_vlm"])
    p.add_argument("--repeat", type=int, default=3, help="best of this many runs of each loop")
    a = p.parse_args(argv)
    print(f"{time.strftime('%Y-%m-%d')}, {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    print(f"{'map':<8} {'python steps/s':>15} {'rust steps/s':>13} {'ratio':>6}")
    for m in a.maps:
        py = max(python_loop_steps_per_s(m, a.steps, s) for s in range(a.repeat))
        rs = max(rust_loop_steps_per_s(m, a.steps, s) for s in range(a.repeat))
        print(f"{m:<8} {py:>15,.0f} {rs:>13,.0f} {py / rs:>6.2f}")


if __name__ == "__main__":
    main()
