"""A student's wall follower for the sonar lab, the way course scripts are written: motors set
before the start, the right-hand sonars read each step, the pose as a matrix and a quaternion,
joint and parameter calls along the way."""
import math
import sys

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')

print('CoppeliaSim', sim.getInt32Param(sim.intparam_program_version))
sim.setInt32Param(sim.intparam_speedmodifier, 1)
robot = sim.getObject('/PioneerP3DX')
left = sim.getObject('/PioneerP3DX/leftMotor')
right = sim.getObject('/PioneerP3DX/rightMotor')
sonars = [sim.getObject(f'/PioneerP3DX/ultrasonicSensor[{i}]') for i in range(16)]
print('objects in the robot', len(sim.getObjectsInTree(robot)), 'sonars',
      len(sim.getObjectsInTree(robot, sim.object_proximitysensor_type)))
print('script', sim.getScript(sim.scripttype_childscript, robot))
try:
    sim.callScriptFunction('sysCall_init', sim.getScript(sim.scripttype_main))
except Exception as e:
    print('no script:', str(e).split(' (')[0])
sim.setShapeColor(robot, None, sim.colorcomponent_ambient_diffuse, [1, 0, 0])
for m in (left, right):
    sim.setJointTargetForce(m, 10.0)
    sim.setJointPosition(m, 0.0)
    sim.setJointTargetVelocity(m, 2.0)  # set while stopped: the scene's value from the start

sim.setStepping(True)
sim.startSimulation()
start = sim.getSystemTime()
while sim.getSimulationTime() < 20:
    front = [sim.handleProximitySensor(sonars[i]) for i in (3, 4)]
    side = [sim.readProximitySensor(sonars[i]) for i in (6, 7)]
    near = min([d for r, d, *_ in front if r] or [1.0])
    wall = min([d for r, d, *_ in side if r] or [1.0])
    if near < 0.5:
        v_left, v_right = -1.0, 1.0
    else:
        turn = max(-1.0, min(1.0, 4.0 * (wall - 0.4)))
        v_left, v_right = 3.0 + turn, 3.0 - turn
    sim.setJointTargetVelocity(left, v_left)
    sim.setJointTargetVelocity(right, v_right)
    sim.step()
sim.wait(0.5)
m = sim.getObjectMatrix(robot, sim.handle_world)
q = sim.getObjectQuaternion(robot, sim.handle_world)
heading = math.atan2(m[4], m[0])
print(f'at {m[3]:.3f} {m[7]:.3f} heading {heading:.3f} quaternion w {q[3]:.3f}')
print('left wheel', round(sim.getObjectFloatParam(left, sim.jointfloatparam_velocity), 3), 'rad/s',
      'force', sim.getJointForce(left))
target = sim.buildMatrix([m[3], m[7], 0.0], [0.0, 0.0, heading])
print('built matches', all(abs(a - b) < 1e-9 for a, b in zip(target[:3], m[:3])))
print('system time advanced', sim.getSystemTime() > start)
sim.stopSimulation()
