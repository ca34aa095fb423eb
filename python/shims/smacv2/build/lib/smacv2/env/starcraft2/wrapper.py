"""`smacv2.env.starcraft2.wrapper`: where SMACv2 defines its capability wrapper."""

from avacraft.smacv2 import StarCraftCapabilityEnvWrapper

__all__ = ["StarCraftCapabilityEnvWrapper"]
