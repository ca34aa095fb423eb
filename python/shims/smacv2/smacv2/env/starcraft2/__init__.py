__avacraft__ = True
