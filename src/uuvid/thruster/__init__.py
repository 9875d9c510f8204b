"""uuvid.thruster"""
