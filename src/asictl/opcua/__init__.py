"""An OPC UA server on a live board (asyncua, the ``opcua`` extra): docs/opcua.md."""
