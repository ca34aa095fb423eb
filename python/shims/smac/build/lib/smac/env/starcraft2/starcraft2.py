"""`smac.env.starcraft2.starcraft2`: where SMAC defines `StarCraft2Env`."""

from avacraft import StarCraft2Env

__all__ = ["StarCraft2Env"]
