"""A camera script for the road lab: the lab loaded by name, its first robot's camera read
in each of the ways course scripts read it (the pre-4.6 call too), a steering rule on the
image's brightest columns."""
import struct
import sys

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')
sim.loadScene('road_follow')
print('scene', sim.getStringParam(sim.stringparam_scene_name))
robot = sim.getObject('/PioneerP3DX[0]')
camera = sim.getObject('/PioneerP3DX[0]/Vision_sensor')  # as CoppeliaSim 4.6 and 4.7 name a new one
try:
    sim.getObject('/PioneerP3DX[0]/visionSensor')  # CoppeliaSim 4.8's name: not this scene's
    print('4.8 name found')
except Exception as e:
    print('4.8 name refused', "'/PioneerP3DX[0]/Vision_sensor'" in str(e))
print('before a step', sim.readVisionSensor(camera))
left = sim.getObject('/PioneerP3DX[0]/leftMotor')
right = sim.getObject('/PioneerP3DX[0]/rightMotor')
sim.setStepping(True)
sim.startSimulation()
for _ in range(60):
    sim.handleVisionSensor(camera)
    image, w, h = sim.getVisionSensorCharImage(camera)
    row = image[3 * w * (h // 4):3 * w * (h // 4 + 1)]  # a row a quarter up from the bottom
    bright = [x for x in range(w) if sum(row[3 * x:3 * x + 3]) > 600]
    error = (sum(bright) / len(bright) - w / 2) / (w / 2) if bright else 0.0
    sim.setJointTargetVelocity(left, 4.0 + 2.0 * error)
    sim.setJointTargetVelocity(right, 4.0 - 2.0 * error)
    sim.step()
result, packet = sim.readVisionSensor(camera)
depth, res = sim.getVisionSensorDepth(camera, 1)
metres = struct.unpack(f'<{res[0] * res[1]}f', depth)
print('packet', len(packet), 'mean intensity', round(packet[10], 3))
print('nearest floor', round(min(metres), 2), 'm; farthest', round(max(metres), 2), 'm')
x, y, _ = sim.getObjectPosition(robot, sim.handle_world)
print(f'robot at {x:.2f} {y:.2f}')
sim.stopSimulation()
