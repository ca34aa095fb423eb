#!/usr/bin/env python3
"""Measures the training throughput of JaxMARL's recurrent PPO baselines on SMAX.

The peer's own baseline script is imported unchanged from a JaxMARL checkout,
its own yaml config is loaded, a few keys are overridden, and its
`make_train(config)` is compiled ahead of time, so the timed call excludes JIT
compilation. One JSON line is printed per timed call.

Usage (inside a venv that has jax[cpu], flax, optax, distrax, hydra-core,
omegaconf and wandb, and where `jaxmarl` is importable or the checkout is given):

    python tools/peer/jaxmarl_train_bench.py --jaxmarl /work/peer/JaxMARL \
        --algo ippo --map 3m [--total-timesteps N] [--set KEY=VALUE ...] [--repeats R]

Steps are counted as JaxMARL's loop does: NUM_UPDATES = TOTAL_TIMESTEPS //
NUM_STEPS // NUM_ENVS updates, each collecting NUM_ENVS x NUM_STEPS environment
steps (one step of one SMAX environment with all of its agents acting), so
steps_per_s = NUM_UPDATES * NUM_ENVS * NUM_STEPS / run_s. The timed call covers
the whole training loop: rollouts, GAE, the PPO epochs and the script's own
per-update logging callback (routed to a disabled wandb run).
"""
import argparse
import importlib.util
import json
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

# Baseline script and fallback config name per algorithm, relative to the checkout.
ALGOS = {
    "ippo": ("baselines/IPPO/ippo_rnn_smax.py", "ippo_rnn_smax"),
    "mappo": ("baselines/MAPPO/mappo_rnn_smax.py", "mappo_homogenous_rnn_smax"),
}


class BenchError(Exception):
    """A problem the user can fix (path, map, config); printed without a traceback."""


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--jaxmarl", required=True, help="path of the JaxMARL checkout")
    p.add_argument("--algo", choices=sorted(ALGOS), default="ippo")
    p.add_argument("--map", default="3m", help="SMAX map name (the config's MAP_NAME), e.g. 3m, 2s3z")
    p.add_argument("--total-timesteps", type=int, default=524_288,
                   help="TOTAL_TIMESTEPS override (default 524288 = 32 updates at 128 envs x 128 steps)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--config", help="yaml config to use instead of the script's own")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key; VALUE is parsed as YAML; dots address nested keys "
                        "(ENV_KWARGS.attack_mode=closest); repeatable")
    p.add_argument("--repeats", type=int, default=1, help="timed calls of the compiled function")
    return p.parse_args(argv)


def load_module(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise BenchError(f"cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except ImportError as e:
        raise BenchError(f"importing {path} failed: {e} (is the venv with JaxMARL's dependencies active?)") from e
    return module


def config_path_for(script: Path, fallback_name: str) -> Path:
    """The yaml the script's @hydra.main points at: config_path/config_name next to the script."""
    src = script.read_text()
    cfg_dir = re.search(r"config_path\s*=\s*[\"']([^\"']+)[\"']", src)
    cfg_name = re.search(r"config_name\s*=\s*[\"']([^\"']+)[\"']", src)
    directory = script.parent / (cfg_dir.group(1) if cfg_dir else "config")
    name = cfg_name.group(1) if cfg_name else fallback_name
    return directory / (name if name.endswith(".yaml") else name + ".yaml")


def parse_value(text: str):
    import yaml
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    return _coerce_number(value)


def _coerce_number(value):
    # PyYAML (YAML 1.1) reads "1e7" as a string; the scripts expect numbers.
    if isinstance(value, str):
        try:
            return float(value) if re.fullmatch(r"[-+]?\d+(\.\d*)?[eE][-+]?\d+", value) else value
        except ValueError:
            return value
    return value


def load_config(path: Path) -> dict:
    if not path.is_file():
        raise BenchError(f"config file not found: {path}")
    try:
        from omegaconf import OmegaConf
        cfg = OmegaConf.load(path)
        try:
            return OmegaConf.to_container(cfg, resolve=True)
        except Exception:
            # e.g. ENTITY: ${oc.env:WANDB_ENTITY} with the variable unset; wandb is disabled anyway.
            return OmegaConf.to_container(cfg, resolve=False)
    except ImportError:
        import yaml
        raw = yaml.safe_load(path.read_text()) or {}
        return {k: _coerce_number(v) for k, v in raw.items()}


def apply_override(config: dict, item: str):
    if "=" not in item:
        raise BenchError(f"--set expects KEY=VALUE, got {item!r}")
    key, text = item.split("=", 1)
    parts = key.strip().split(".")
    node = config
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise BenchError(f"--set {key}: {part} is not a mapping in the config")
    node[parts[-1]] = parse_value(text)


def git_commit(checkout: Path) -> str:
    try:
        out = subprocess.run(["git", "-C", str(checkout), "rev-parse", "HEAD"],
                             capture_output=True, text=True, timeout=10)
        return out.stdout.strip() if out.returncode == 0 else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def disable_wandb(module):
    """The scripts log through wandb.log inside an io_callback; give them a disabled run."""
    os.environ["WANDB_MODE"] = "disabled"
    os.environ.setdefault("WANDB_SILENT", "true")
    wb = getattr(module, "wandb", None)
    if wb is None:
        return "absent"
    try:
        wb.init(mode="disabled")
        wb.log({"probe": 0})  # must be a no-op now
        return "disabled"
    except Exception:
        class _NoWandb:  # last resort: a stand-in that drops every log call
            def log(self, *a, **k):
                pass

            def init(self, *a, **k):
                return None

        module.wandb = _NoWandb()
        return "stubbed"


def main(argv=None):
    args = parse_args(argv)
    checkout = Path(args.jaxmarl).expanduser().resolve()
    if not checkout.is_dir():
        raise BenchError(f"--jaxmarl: no such directory: {checkout}")
    rel_script, fallback_cfg = ALGOS[args.algo]
    script = checkout / rel_script
    if not script.is_file():
        raise BenchError(f"{args.algo}: baseline script not found: {script}")
    if args.total_timesteps <= 0 or args.repeats <= 0:
        raise BenchError("--total-timesteps and --repeats must be positive")

    # Make the checkout's `jaxmarl` package importable if it is not installed.
    if str(checkout) not in sys.path:
        sys.path.insert(0, str(checkout))
    os.environ["WANDB_MODE"] = "disabled"

    module = load_module(script, f"jaxmarl_peer_{args.algo}_rnn_smax")
    make_train = getattr(module, "make_train", None)
    if not callable(make_train):
        raise BenchError(f"{script} defines no make_train(config)")

    config = load_config(Path(args.config) if args.config else config_path_for(script, fallback_cfg))
    config["MAP_NAME"] = args.map
    config["SEED"] = args.seed
    config["WANDB_MODE"] = "disabled"
    config["NUM_SEEDS"] = 1
    for item in args.overrides:
        apply_override(config, item)
    config["TOTAL_TIMESTEPS"] = args.total_timesteps
    for key in ("NUM_ENVS", "NUM_STEPS", "UPDATE_EPOCHS", "NUM_MINIBATCHES", "TOTAL_TIMESTEPS"):
        if key not in config:
            raise BenchError(f"config has no {key}")
        config[key] = int(config[key])

    to_scenario = getattr(module, "map_name_to_scenario", None)
    if to_scenario is not None:
        try:
            to_scenario(config["MAP_NAME"])
        except KeyError:
            known = sorted(getattr(sys.modules.get(to_scenario.__module__), "MAP_NAME_TO_SCENARIO", {}))
            raise BenchError(f"unknown SMAX map {config['MAP_NAME']!r}; known: {', '.join(known)}")

    import jax

    wandb_state = disable_wandb(module)
    train = make_train(config)  # fills NUM_UPDATES, NUM_ACTORS, ... in config
    updates = int(config["NUM_UPDATES"])
    if updates < 1:
        raise BenchError(f"TOTAL_TIMESTEPS {config['TOTAL_TIMESTEPS']} is below one update "
                         f"(NUM_ENVS x NUM_STEPS = {config['NUM_ENVS'] * config['NUM_STEPS']})")
    env_steps = updates * config["NUM_ENVS"] * config["NUM_STEPS"]
    agents = int(config.get("NUM_ACTORS", 0)) // config["NUM_ENVS"] or None

    rng = jax.random.PRNGKey(config["SEED"])
    t0 = time.perf_counter()
    compiled = jax.jit(train).lower(rng).compile()
    compile_s = time.perf_counter() - t0

    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count()
    for i in range(args.repeats):
        load = os.getloadavg()
        ru0 = resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.perf_counter()
        out = compiled(rng)
        jax.block_until_ready(out)
        jax.effects_barrier()  # the per-update logging callbacks have run too
        run_s = time.perf_counter() - t0
        ru1 = resource.getrusage(resource.RUSAGE_SELF)
        # CPU time this process got during the call: with other work on the machine,
        # steps per CPU-second is less disturbed than steps per wall-second.
        cpu_s = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
        record = {
            "peer": "jaxmarl",
            "algo": args.algo,
            "map": config["MAP_NAME"],
            "envs": config["NUM_ENVS"],
            "num_steps": config["NUM_STEPS"],
            "epochs": config["UPDATE_EPOCHS"],
            "minibatches": config["NUM_MINIBATCHES"],
            "gru": config.get("GRU_HIDDEN_DIM"),
            "fc": config.get("FC_DIM_SIZE"),
            "total_timesteps": config["TOTAL_TIMESTEPS"],
            "updates": updates,
            "env_steps": env_steps,
            "agents": agents,
            "compile_s": round(compile_s, 3),
            "run_s": round(run_s, 3),
            "steps_per_s": round(env_steps / run_s, 1),
            "agent_steps_per_s": round(env_steps * agents / run_s, 1) if agents else None,
            "cpu_s": round(cpu_s, 3),
            "steps_per_cpu_s": round(env_steps / cpu_s, 1) if cpu_s > 0 else None,
            "jax_version": jax.__version__,
            "jaxmarl_commit": git_commit(checkout),
            "threads": cpus,
            "xla_flags": os.environ.get("XLA_FLAGS", ""),
            "device": str(jax.devices()[0]),
            "loadavg_before": [round(x, 2) for x in load],
            "repeat": i,
            "wandb": wandb_state,
        }
        print(json.dumps(record), flush=True)


if __name__ == "__main__":
    try:
        main()
    except BenchError as e:
        print(f"jaxmarl_train_bench: error: {e}", file=sys.stderr)
        sys.exit(2)
