"""A script that builds its own scene in an empty CoppeliaSim: a floor, a wall across the way,
a Pioneer from CoppeliaSim's model library, a goal marker; then it drives at the goal and
stops at the wall. Saving the scene is not possible everywhere: it reports why and goes on."""
import sys

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')

floor = sim.createPrimitiveShape(sim.primitiveshape_plane, [10, 10, 0], 0)
wall = sim.createPrimitiveShape(sim.primitiveshape_cuboid, [0.2, 4.0, 0.5], 8 + 16)  # respondable, static
sim.setObjectPosition(wall, [2.0, 0.0, 0.25], sim.handle_world)
sim.setObjectAlias(wall, 'barrier')
post = sim.createPrimitiveShape(sim.primitiveshape_cylinder, [0.3, 0.3, 0.5], 8)
sim.setObjectPosition(post, [0.0, 2.0, 0.25], sim.handle_world)
sim.removeObject(post)
sim.setShapeColor(wall, None, sim.colorcomponent_ambient_diffuse, [0.8, 0.2, 0.2])
robot = sim.loadModel(sim.getStringParam(sim.stringparam_resourcesdir) + '/models/robots/mobile/pioneer p3dx.ttm')
script = sim.getScript(sim.scripttype_childscript, robot)
if script != -1:  # the model's own Braitenberg script would drive the wheels too
    sim.removeScript(script)
goal = sim.createDummy(0.05)
sim.setObjectAlias(goal, 'goal')
sim.setObjectMatrix(goal, sim.buildMatrix([3.0, 0.0, 0.0], [0.0, 0.0, 0.0]), sim.handle_world)
tag = sim.createDummy(0.02)
sim.setObjectParent(tag, robot, False)
print('goal found', sim.getObject('/goal') == goal, 'tag parent is the robot', sim.getObjectParent(tag) == robot)
print('shapes', len(sim.getObjectsInTree(sim.handle_scene, sim.sceneobject_shape, 2)))
try:
    sim.saveScene('/tmp/my_scene.ttt')
except Exception as e:
    print('not saved:', str(e).split(' (')[0][:40])

left = sim.getObject('/PioneerP3DX/leftMotor')
right = sim.getObject('/PioneerP3DX/rightMotor')
sim.setStepping(True)
sim.startSimulation()
for m in (left, right):
    sim.setJointTargetVelocity(m, 6.0)
while sim.getSimulationTime() < 10:
    sim.step()
x, y, _ = sim.getObjectPosition(robot, goal)
print(f'robot to goal: {x:.2f} {y:.2f}')
print('collided', sim.checkCollision(robot, sim.handle_all)[0])
sim.stopSimulation()
print('scene closed', sim.closeScene())
