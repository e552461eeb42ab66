"""Exporters render the IR into files; they compute nothing the IR does not already hold."""
