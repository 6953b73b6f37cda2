"""The robot's C firmware (C sources, Makefile), installed as package data so an installed
wheel can build it too: ``wheelleg.hil.firmware_build.build()`` (docs/firmware.md)."""
