"""uuvid.report"""
