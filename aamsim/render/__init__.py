"""Pictures of the traffic drawn on the server side: frames as images (``render()``), videos and figures."""
