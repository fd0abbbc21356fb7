"""How many variants run, where, and where the results go: the sweep spec and its variant table
(`spec`), the chunk runner (`chunks`), the Ray executor (`cluster`), result folders and Parquet
(`results`, `storage`)."""
