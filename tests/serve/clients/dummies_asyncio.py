"""The same first script for the asyncio client: many requests in flight at once (each on its
own socket), a free-running and a stepped simulation, everything cleaned up."""
import asyncio
import sys

from coppeliasim_zmqremoteapi_client.asyncio import RemoteAPIClient

port = int(sys.argv[1]) if len(sys.argv) > 1 else 23000


async def main():
    print('Program started')
    async with RemoteAPIClient('localhost', port) as client:
        sim = await client.require('sim')
        handles = await asyncio.gather(*[sim.createDummy(0.01) for _ in range(20)])
        await asyncio.gather(*[sim.setObjectPosition(h, -1, [0.01 * i, 0.02 * i, 0.0])
                               for i, h in enumerate(handles)])
        await sim.startSimulation()
        while (t := await sim.getSimulationTime()) < 0.3:
            await sim.addLog(sim.verbosity_scriptinfos, f'{t:.2f}')
        await sim.stopSimulation()
        while sim.simulation_stopped != await sim.getSimulationState():
            await asyncio.sleep(0.05)
        await sim.setStepping(True)
        await sim.startSimulation()
        while await sim.getSimulationTime() < 0.5:
            await sim.step()
        await sim.stopSimulation()
        x, y, _ = await sim.getObjectPosition(handles[-1], sim.handle_world)
        print(f'last dummy at {x:.2f} {y:.2f}')
        await asyncio.gather(*[sim.removeObject(h) for h in handles])
    print('Program ended')

asyncio.run(main())
