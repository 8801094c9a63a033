"""The fleet's script: a whole fleet's tick in a few round trips on CoppeliaSim.

Where it sits: ``labsim scene`` (``scene_builder``) puts this script in the scene it builds,
as the child script of a dummy aliased ``labsimFleet``. The backend (``fleet.Fleet``) finds
that dummy and calls the script's two functions with ``sim.callScriptFunction(name,
scriptHandle, ...)`` (the CoppeliaSim 4.6 form: the function's name, then the script's
handle from ``sim.getScript``), instead of one request per sonar, pose and wheel:

* ``labsimSense(plan)`` returns every reading the behaviour needs for every robot;
* ``labsimAct(commands)`` sets every wheel target that changed;
* ``labsimParts(plan)`` returns a mechanism's readings: ``plan`` is ``[joints, forces,
  bodies]`` (handles), the reply ``[[position, velocity] per joint, readForceSensor's three
  values per force sensor, [position, orientation] per body (world frame)]``.

With the step (two round trips: CoppeliaSim answers "wait", the client says "executed"), a
tick is 3 round trips for the whole fleet, 4 when a wheel command changed. A scene without
the dummy (one built by hand) is driven object by object, as before. ``labsim serve --empty``
answers these functions (``script_host``) without running Lua: it does what the Lua below
does, through the same ``sim.*`` handlers.

The plan, one entry per robot: ``[robot, collideWith, flags, sonars, cameras]`` where flags
bit 0 asks for the position, bit 1 the orientation, bit 2 the velocity, and sonars and cameras
are lists of handles. The reply, one entry per robot: ``[sonars, images, position,
orientation, velocity, collision]``, each reading exactly what the per-object call returns
(``readProximitySensor``'s five values, ``getVisionSensorImg``'s image and resolution,
``getObjectVelocity``'s two vectors, ``checkCollision``'s result and pair); what was not
asked for is an empty list. ``commands`` is a flat list ``[motor, velocity, motor, velocity,
...]``.

The plan and commands go with every call: the script keeps no state, so a restarted
simulation or a second client cannot confuse it.
"""
from __future__ import annotations

from typing import Any

ALIAS = "labsimFleet"  # the dummy that carries the script
SENSE, ACT, PARTS = "labsimSense", "labsimAct", "labsimParts"
POSITION, ORIENTATION, VELOCITY = 1, 2, 4  # the plan's flags

# Lua 5.4 (CoppeliaSim 4.6 and later). Every call is one CoppeliaSim 4.6 documents.
LUA = """\
-- labsim: a fleet's tick in two calls (labsim scene put this script here; docs/coppeliasim.md)

function labsimSense(plan)
    local out = {}
    for i, p in ipairs(plan) do
        local robot, other, flags = p[1], p[2], p[3]
        local sonars, images = {}, {}
        for k, h in ipairs(p[4]) do
            sonars[k] = {sim.readProximitySensor(h)}
        end
        for k, h in ipairs(p[5]) do
            local img, res = sim.getVisionSensorImg(h)
            images[k] = {img, res}
        end
        local pos, ori, vel = {}, {}, {}
        if flags & 1 ~= 0 then pos = sim.getObjectPosition(robot, sim.handle_world) end
        if flags & 2 ~= 0 then ori = sim.getObjectOrientation(robot, sim.handle_world) end
        if flags & 4 ~= 0 then
            local linear, angular = sim.getObjectVelocity(robot)
            vel = {linear, angular}
        end
        out[i] = {sonars, images, pos, ori, vel, {sim.checkCollision(robot, other)}}
    end
    return out
end

function labsimParts(plan)
    local joints, forces, bodies = {}, {}, {}
    for k, h in ipairs(plan[1]) do
        joints[k] = {sim.getJointPosition(h), sim.getJointVelocity(h)}
    end
    for k, h in ipairs(plan[2]) do
        forces[k] = {sim.readForceSensor(h)}
    end
    for k, h in ipairs(plan[3]) do
        bodies[k] = {sim.getObjectPosition(h, sim.handle_world), sim.getObjectOrientation(h, sim.handle_world)}
    end
    return {joints, forces, bodies}
end

function labsimAct(commands)
    for k = 1, #commands, 2 do
        sim.setJointTargetVelocity(commands[k], commands[k + 1])
    end
end
"""


def find_script(conn: Any) -> int:
    """The fleet script's handle in the scene a ``connection.Connection`` reaches, or -1 when
    the scene has none (one built by hand): then the backend reads object by object."""
    if not hasattr(conn.sim, "callScriptFunction"):
        return -1
    h = conn.call("sim.getObject", f"/{ALIAS}", {"noError": True})
    if h < 0:
        return -1
    # sim.getScript(int scriptType, int objectHandle): CoppeliaSim 4.6, -1 when there is none
    script = conn.call("sim.getScript", getattr(conn.sim, "scripttype_childscript", 1), h)
    if not isinstance(script, int) or isinstance(script, bool) or script < 0:
        return -1
    return int(conn.name(script, f"the fleet script on '/{ALIAS}'"))
