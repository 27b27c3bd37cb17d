"""Errors a user can cause. The CLI turns them into one line and exit status 2."""
from __future__ import annotations


class SceneError(Exception):
    """Bad user input: a scene, an image, a flag.

    Parameters
    ----------
    message : what is wrong, in words a user understands.
    file : the file concerned (scene or image), if any.
    path : the JSON path of the offending value inside the scene, e.g. ``layers[2].mask``.
    """

    def __init__(self, message: str, *, file: str | None = None, path: str | None = None):
        self.message = message
        self.file = file
        self.path = path
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.file:
            where = f"{self.file}"
            if self.path:
                where += f": {self.path}"
            where += ": "
        elif self.path:
            where = f"{self.path}: "
        return f"{where}{self.message}"


class ImageError(SceneError):
    """An image that is missing, unreadable, corrupt or too large."""


def one_line(e: BaseException) -> str:
    """The first line of an error's message (its type's name when it has none)."""
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__
