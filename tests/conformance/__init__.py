"""One scenario suite, run over the simulated network and the WebSocket mesh."""
