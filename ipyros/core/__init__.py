"""The core: a node as plain data, and the rules on it. Plain Python: no ROS, rich or IPython.

- :mod:`.model`: a node's declared structure (topics, timers, services, params, basenode);
- :mod:`.plan`: which endpoints must run for a model (the wrapping semantics of the paper's
  figure 1), and :mod:`.remapping`: how a wrapping node names and remaps its basenode;
  :mod:`.nodecode`: the name a node's Python source gives its node, read and never run;
- :mod:`.names`: ROS names checked and resolved; :mod:`.qos`: QoS as data;
- :mod:`.msgtypes`, :mod:`.msgbuild`: message classes found by name, messages built from
  YAML checked field by field, and shown as YAML (the same on both ROS);
- :mod:`.slots`: a handler slot, whose function is swapped live, its figures counted;
- :mod:`.versions`, :mod:`.code`: handler versions and their source; :mod:`.journal`: the
  history of changes; :mod:`.records`: what a node reports (status, history, interface);
- :mod:`.graph`: a snapshot of the live graph; :mod:`.actions`: what an action's handler gets
  and what a sent goal gives back; :mod:`.userdata`: YAML and JSON from the user, with
  limits; :mod:`.errors`: one-line errors; :mod:`.text`: counts that read as English.

May import: nothing of ipyros's outside it (the bottom layer).
"""

__all__ = ["actions", "code", "errors", "graph", "journal", "model", "msgbuild", "msgtypes", "names", "nodecode",
           "plan", "qos", "records", "remapping", "slots", "text", "userdata", "versions"]
