"""Tracing: the trace job, ray-triangle intersection, the bounce loop and the process pool."""
