"""SMACv2's package name over AVACraft (`pip install ./python/shims/smacv2`): its capability
wrapper draws teams and start positions from SMACv2's configs on AVACraft's engine."""

__avacraft__ = True
