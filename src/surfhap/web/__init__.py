"""surfhap.web: the one web app (touch page, force-feedback page, study page), its request
guard, its server and the link to the engine in another process.

Importing the package is cheap; FastAPI, Starlette and uvicorn (the ``live`` extra) are
imported when an app is built or served.
"""

from surfhap.web.app import create_app

__all__ = ["create_app"]
