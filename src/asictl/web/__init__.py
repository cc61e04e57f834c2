"""The web page and REST API on a live board (docs/web.md): ``serve --http``."""
