"""`smacv2.env.starcraft2.starcraft2`: where SMACv2 defines `StarCraft2Env`."""

from avacraft import StarCraft2Env

__all__ = ["StarCraft2Env"]
