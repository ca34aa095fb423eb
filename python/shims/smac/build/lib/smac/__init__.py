"""SMAC's package name over AVACraft (`pip install ./python/shims/smac`).

`from smac.env import StarCraft2Env` gives `avacraft.StarCraft2Env`: SMAC's 23 map names
mean SMAC's maps (engine/scenarios/smac/, Liberty unit data, SMAC's episode limits), and
every keyword of PyMARL's `sc2.yaml` is accepted.
"""

__avacraft__ = True
