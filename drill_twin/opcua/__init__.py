"""OPC UA access to the twin (issue 34): the address space, the write validation, the
control arbitration with its heartbeat watchdog and safe state, the security files, and the
asyncua server.  Nothing here imports ROS: :mod:`drill_twin.ros.opcua_bridge` connects the
server to the twin's topics and services (docs/opcua.md).
"""
