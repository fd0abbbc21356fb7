"""Sizing a motor and its gear ratio: each motor's ratio window over its gearhead series (`windows`) and the
requirement sheet a vendor is sent (`requirements`). The session itself is `batchveh.size`."""
