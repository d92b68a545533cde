"""What a grasp's joint angles say about the object, without training (thesis ch. 2-3).

``signature`` (the FCI and the proprioceptive shape signature, eqs. 2.1-2.4), ``patterns`` (the
theoretical signatures and the DTW identification), ``rotation`` (the object's turn from the
signature's slope), ``temporal`` (the G image, Gbin and the non-contact detectors of ch. 3),
``shape_model`` and ``shape_fit`` (fitting each shape family's geometry to the joint angles) and
``contact`` (whether a grasp touched enough to say anything). Pure functions on arrays and
records: usable on a real hand's data as on simulated grasps.
"""
