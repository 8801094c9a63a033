"""``labsim serve``: a stand-in for CoppeliaSim's ZMQ remote API, answered by the pymunk backend.

An application of its own, not a backend: it stands above the embedded simulator and answers
what the client backend (``labsim.backends.coppeliasim``) and students' scripts ask.
``server`` (the wire loop), ``wire_limits`` (what is accepted on the wire), ``sim_api`` (the
``sim.*`` functions), ``simulation`` (the pymunk backend behind the scene), ``scene_tree``
(objects and CoppeliaSim's path language), ``scene_edit`` and ``mechanism_edit`` (a scene
built from remote calls) and ``script_host`` (the fleet script's functions).
"""
