"""Recording the bus into MCAP files and replaying them (`gazed record`, `gazed replay`)."""
