"""A Pioneer script written the way public tutorials write them: relative './x' paths with no
proxy, handles kept in a numpy array (so they come back as floats), the sensors found by
walking the robot's children with getObjectChild, checkProximitySensor against everything,
the camera through the older getVisionSensorImage, int32 and float signals to talk to
another script, and the wheel force set with the older setJointForce."""
import sys

import numpy as np
from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')

robot = sim.getObject('./PioneerP3DX')
motors = np.zeros(2)
motors[0] = sim.getObject('./leftMotor')
motors[1] = sim.getObject('./rightMotor')
sensors = np.zeros(16)
k, i = 0, 0
while True:
    child = sim.getObjectChild(robot, i)
    if child == -1:
        break
    if sim.getObjectAlias(child) == 'ultrasonicSensor':
        sensors[k] = child
        k += 1
    i += 1
print('children', i, 'sonars', k)
camera = sim.getObject('./Vision_sensor')
for m in motors:
    sim.setJointForce(m, 20.0)
sim.setInt32Signal('state', 0)
sim.setFloatSignal('speed', 2.5)
sim.setStepping(True)
sim.startSimulation()
turns = 0
for _ in range(200):
    speed = sim.getFloatSignal('speed')
    front = [sim.checkProximitySensor(sensors[j], sim.handle_all) for j in (3, 4)]
    near = min([d for r, d, _ in front if r] or [9999])
    if near <= 0.5:
        sim.setInt32Signal('state', 1)
    state = sim.getInt32Signal('state')
    if state == 1:
        turns += 1
        sim.setJointTargetVelocity(motors[0], -speed)
        sim.setJointTargetVelocity(motors[1], speed)
        if near > 0.8:
            sim.setInt32Signal('state', 0)
    else:
        sim.setJointTargetVelocity(motors[0], speed)
        sim.setJointTargetVelocity(motors[1], speed)
    sim.step()
image = sim.getVisionSensorImage(camera)
print('image', len(image), 'values in [0, 1]', all(0.0 <= v <= 1.0 for v in image))
print('turning steps', turns > 0, 'state', sim.getInt32Signal('state') in (0, 1))
sim.clearInt32Signal('state')
print('cleared', sim.getInt32Signal('state'))
sim.stopSimulation()
print('done at', round(sim.getSimulationTime(), 2))
