"""ncsim: a SINUMERIK 840D-style G-code interpreter and HSM feed-rate / cycle-time simulator.

Data flow (one module per step)::

    program text --parse--> blocks --interpret--> Path (segments)
        --limits + plan--> Motion (feed law) --sample--> Trace --> reports, plots, gap diagnosis
"""
__version__ = "0.1.0"
