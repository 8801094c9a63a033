"""``labsim scene``: the scene a behaviour needs, built in a running CoppeliaSim through the
client's connection (``scene`` for robots and the world, ``mechanism`` for a world's
mechanism, ``command`` for the subcommand)."""
