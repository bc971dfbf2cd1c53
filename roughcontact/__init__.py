"""roughcontact: multiscale contact mechanics of rough elastic half-spaces."""
__version__ = "0.1.0"
