"""fit: estimation of rhythmjax's parameters with optimistix (camera, noise, walking model).

Depends on `rhythmjax`; `rhythmjax` never imports `fit`.
"""

__all__: list[str] = []
