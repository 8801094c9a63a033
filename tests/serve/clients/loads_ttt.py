"""A script shaped as CoppeliaSim's examples that open a scene of CoppeliaSim's own: it loads a
.ttt file from CoppeliaSim's scenes folder before anything else."""
import sys

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
print('Program started')
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')
sim.loadScene(sim.getStringParam(sim.stringparam_scenedefaultdir) + '/messaging/pControllerViaRemoteApi.ttt')
joint = sim.getObject('/Cuboid[0]/joint')
print('Program ended')
