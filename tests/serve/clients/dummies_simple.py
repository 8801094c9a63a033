"""A first script, shaped as CoppeliaSim's simple example: dummies set out in a row, a
simulation run free and then stepped, a log line a step, the dummies removed."""
import sys
import time

from coppeliasim_zmqremoteapi_client import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000
print('Program started')
client = RemoteAPIClient('localhost', port)
sim = client.require('sim')

handles = [sim.createDummy(0.01) for _ in range(10)]
for i, h in enumerate(handles):
    sim.setObjectPosition(h, -1, [0.1 * i, 0.05 * i, 0.01 * i])  # the order before CoppeliaSim 4.5

sim.startSimulation()
while (t := sim.getSimulationTime()) < 0.5:
    sim.addLog(sim.verbosity_scriptinfos, f'free-running: {t:.2f} s')
sim.stopSimulation()
while sim.getSimulationState() != sim.simulation_stopped:
    time.sleep(0.1)

sim.setStepping(True)
sim.startSimulation()
steps = 0
while sim.getSimulationTime() < 1:
    sim.addLog(sim.verbosity_scriptinfos, 'stepping')
    sim.step()
    steps += 1
sim.stopSimulation()
print('steps', steps)
print('last dummy at', [round(v, 3) for v in sim.getObjectPosition(handles[-1], sim.handle_world)])
for h in handles:
    sim.removeObject(h)
print('dummies left', len(sim.getObjectsInTree(sim.handle_scene, sim.sceneobject_dummy)))
print('Program ended')
