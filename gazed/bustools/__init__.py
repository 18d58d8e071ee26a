"""The operator's view of a running rig: `gazed tail`, `gazed status`, `gazed latency`.

Each connects to a rig's bus as a client (endpoints from `--rig RIG`'s [bus], or `--connect`),
listens, and prints; each exits 1 with a clear message when nothing answers. `listen` holds
what they share: which bus to join, and each sample as the tools see it.
"""
