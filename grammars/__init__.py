"""The Lark grammar of the 840D program language (installed as the data package ncsim.nc.grammars)."""
