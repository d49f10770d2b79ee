"""Wavekeep's companion as a BlueOS extension: a web page and BlueOS's service registration beside the companion.

:mod:`.settings` is what the pilot sets on the page (validated, kept as JSON in the bind-mounted data folder),
:mod:`.service` runs the companion (``firmware_py.companion``) on BlueOS's MAVLink router and forecast link in
its own thread and answers the page, :mod:`.web` is the FastAPI application, :mod:`.main` the container's entry
point (``python -m blueos.main``). See ``blueos/README.md``.
"""
__version__ = "0.1.0"
"""The extension's version: the image's tag and ``version`` label, and ``/register_service``'s."""
