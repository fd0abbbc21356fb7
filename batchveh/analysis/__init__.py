"""What the numbers mean: motor sizing against a catalogue (`motors`), figures (`plot`) and Sobol'
sensitivity indices (`sensitivity`)."""
