"""Exporters render the IR and the probes' results (``registry.Probed``) into files; they compute nothing else."""
