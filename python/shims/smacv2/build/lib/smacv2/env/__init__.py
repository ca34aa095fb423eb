"""`smacv2.env`: SMACv2's names, AVACraft's engine."""

from avacraft import StarCraft2Env
from avacraft.smacv2 import StarCraftCapabilityEnvWrapper

__avacraft__ = True
__all__ = ["StarCraft2Env", "StarCraftCapabilityEnvWrapper"]
