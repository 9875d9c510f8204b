"""uuvid.simulate"""
