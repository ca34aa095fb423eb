"""`smac.env`: SMAC's `StarCraft2Env` and `MultiAgentEnv` names, AVACraft's engine."""

from avacraft import StarCraft2Env

from .multiagentenv import MultiAgentEnv

__avacraft__ = True
__all__ = ["MultiAgentEnv", "StarCraft2Env"]
