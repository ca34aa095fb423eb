"""The AVA agent (the paper's VLM agent) from Python.

`Ava(...)` takes the settings a launch file's `ava:` block holds and plays episodes with the
Rust agent, asking the model exactly what `avacraft episode --agent ava` asks; every call is
recorded (`record=`) and can be replayed without the model (`replay=`).

    ava = avacraft.Ava(url="https://api.openai.com/v1", model="gpt-4o-mini", record="runs/ava")
    env = avacraft.Env("3m_vlm")
    result = ava.play(env, seed=1)          # {"result": "win", "steps": ..., "cost": {...}}
    again = avacraft.Ava(replay="runs/ava").play(avacraft.Env("3m_vlm"), seed=1)   # no model called

Without a model: `Ava(synthetic=True)` answers instantly (a crude focus-fire stand-in), and
`Ava(ceiling="kite", config={"prompt": "rich", "actions": "micro"})` is the ceiling back end:
it reads only the prompt and answers as that script would (`focus-fire`, `kite`, `nearest`,
`attack-move`), measuring what the prompt and action set allow a perfect model
(docs/ava.md).
"""

from __future__ import annotations

import json
from typing import Any

from ._avacraft import Ava as _Ava
from ._avacraft import AvacraftError


class Ava(_Ava):
    """AVA with one model: an OpenAI-compatible endpoint (`url` and `model`; the key is read
    from the environment variable `key_env`), a recording (`replay`), the stand-in
    (`synthetic=True`), or the ceiling back end (`ceiling="kite"`, a script's name). `config` holds pipeline settings (`decide_every`, `planner`,
    `priority`, `retrieval`, `roles`, `image`, `text`, `timing`, `sampling`, ...: see the
    README's AVA section); `record` is a folder for the calls (one that holds no recording)."""

    def __new__(
        cls,
        url: str | None = None,
        model: str | None = None,
        *,
        key_env: str = "OPENAI_API_KEY",
        timeout_s: float = 60.0,
        schema: str = "json_schema",
        replay: str | None = None,
        synthetic: bool = False,
        ceiling: str | None = None,
        record: str | None = None,
        config: dict[str, Any] | None = None,
        prices: str | None = None,
        prompts: str | None = None,
    ) -> Ava:
        chosen = [url is not None, replay is not None, synthetic, ceiling is not None]
        if sum(chosen) != 1:
            raise AvacraftError("Ava needs exactly one model: url= and model=, replay=, synthetic=True, or ceiling=SCRIPT")
        scripts = ("focus-fire", "kite", "nearest", "attack-move")
        if ceiling is not None and ceiling not in scripts:
            raise AvacraftError(f"Ava(ceiling={ceiling!r}): the ceiling answers as one of {', '.join(scripts)}")
        if url is not None:
            if not model:
                raise AvacraftError("Ava(url=...) needs model=, the model's name at that endpoint")
            spec_model: dict[str, Any] = {"kind": "openai", "url": url, "model": model, "key_env": key_env, "timeout_s": timeout_s, "schema": schema}
        elif replay is not None:
            spec_model = {"kind": "replay", "dir": str(replay)}
        elif ceiling is not None:
            spec_model = {"kind": "ceiling", "script": ceiling}
        else:
            spec_model = {"kind": "synthetic"}
        spec: dict[str, Any] = {"model": spec_model, "config": dict(config or {})}
        for key, value in (("record", record), ("prices", prices), ("prompts", prompts)):
            if value is not None:
                spec[key] = str(value)
        return super().__new__(cls, json.dumps(spec))

    def play(self, env: Any, seed: int, team: int = 1) -> dict[str, Any]:
        """Plays one episode of `env` (an `avacraft.Env`) from `seed` as `team`; returns
        `{"result", "steps", "trajectory_hash", "cost"}` with the episode's accounting (calls,
        tokens, latency, dollars, repairs, refusals, fallbacks) as a dict."""
        out = dict(super().play(env, seed, team))
        out["cost"] = json.loads(out["cost"])
        return out

    def costs(self) -> list[dict[str, Any]]:
        """Every episode's accounting so far."""
        return json.loads(self.costs_json())

    @property
    def spec(self) -> dict[str, Any]:
        return json.loads(self.spec_json())
