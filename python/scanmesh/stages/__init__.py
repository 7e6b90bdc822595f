"""The reconstruction methods, one module per method, and the options they share."""
