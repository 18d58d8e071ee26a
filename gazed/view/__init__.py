"""The live view in the browser (`gazed view`): frames with overlays, the ground map, live plots
and click-to-select, served by aiohttp over a WebSocket (docs/view.md)."""
