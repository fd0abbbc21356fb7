"""What is simulated: the vehicle and its MJCF (`vehicle`), the wheel-ground models (`tyres`,
`soil`, and `wheels`, their one entry point), the ground's shape (`course`), the motion laws
(`laws`), the scenario kinds (`scenarios`, `missions`) and the registry of sweepable parameters
(`params`). Nothing here imports a higher folder."""

from batchveh.model import missions as _missions  # noqa: F401  (registers the scenario kind 'mission')
