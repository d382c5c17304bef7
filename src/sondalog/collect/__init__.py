"""The collector: sources (loggers, buses, data messages) -> a pure row pipeline -> sinks.

The store's schema (:mod:`sondalog.collect.schema`) is the contract between the collector,
the sinks and the web dashboard.
"""
