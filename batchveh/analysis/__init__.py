"""What the numbers mean: what a motor must deliver (`demand`; sizing against a catalogue is `batchveh.sizing`),
figures (`plot`) and Sobol' sensitivity indices (`sensitivity`)."""
